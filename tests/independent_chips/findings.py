"""Reproducers of the driver findings in FINDINGS.md (all fixed; `test_findings.py` keeps them fixed).

Run: `python tests/independent_chips/findings.py` prints one line per finding.


"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasheet_chips as chips  # noqa: E402
from drivers import ADXL312, HMC5843, ITG3200  # noqa: E402


def f1_itg3200_first_read_after_start_is_a_configured_sample() -> tuple[list[int], list[int]]:
    """F1: read_raw() right after start() must return a sample taken at FS_SEL = 3 (14.375 LSB per deg/s)."""
    clock = chips.ManualClock()
    bus = chips.I2CBus(clock)
    bus.attach(0x68, chips.ITG3200(clock, rate_dps=(8.0, -16.0, 80.0)))
    driver = ITG3200(bus, sleep=clock.sleep)
    driver.start()
    return list(driver.read_raw()), [115, -230, 1150]


def f2a_hmc5843_restart_after_a_program_left_another_gain() -> tuple[list[int], list[int]]:
    """F2a: a previous program left gain 970 LSB/Ga in continuous mode; start() then read_raw() at 1300 LSB/Ga."""
    clock = chips.ManualClock()
    bus = chips.I2CBus(clock)
    bus.attach(0x1E, chips.HMC5843(clock, field_ga=(0.2, -0.1, 0.4)))
    bus.write_byte_data(0x1E, 0x01, 0x40)  # CONFIG_B GN = 2 (970 LSB/Ga)
    bus.write_byte_data(0x1E, 0x02, 0x00)  # continuous
    clock.sleep(1.0)
    driver = HMC5843(bus, sleep=clock.sleep)
    driver.start()
    return list(driver.read_raw()), [260, -130, 520]


def f2b_hmc5843_stale_power_up_measurement() -> tuple[list[int], list[int]]:
    """F2b: chip powered up in single-measurement mode (HMC5883 default, [U] for HMC5843) with field A; the field
    is B when start() runs; read_raw() right after start() must report B."""
    clock = chips.ManualClock()
    bus = chips.I2CBus(clock)
    chip = bus.attach(0x1E, chips.HMC5843(clock, field_ga=(0.5, 0.5, 0.5), power_up_mode=0x01))
    clock.sleep(0.05)
    bus.read_byte_data(0x1E, 0x09)  # any access: the power-up measurement has completed by now
    chip.field_ga = chips.np.array([0.2, -0.1, 0.4])
    clock.sleep(5.0)
    driver = HMC5843(bus, sleep=clock.sleep)
    driver.start()
    return list(driver.read_raw()), [260, -130, 520]


def f2c_hmc5843_first_read_with_a_non_default_gain() -> tuple[list[int], list[int]]:
    """F2c: HMC5843(gain=970): the driver's own rule (first conversion after a gain change uses the old gain) is
    not honoured, because read_raw() re-reads the sample start() meant to discard."""
    clock = chips.ManualClock()
    bus = chips.I2CBus(clock)
    bus.attach(0x1E, chips.HMC5843(clock, field_ga=(0.2, -0.1, 0.4)))
    driver = HMC5843(bus, gain=970, sleep=clock.sleep)
    driver.start()
    return list(driver.read_raw()), [194, -97, 388]


def f3_adxl312_part_slower_than_typical_turn_on() -> tuple[list[int], list[int]]:
    """F3: a part 0.5 ms slower than the typical turn-on time (tau + 1.1 ms = 11.1 ms at 100 Hz)."""
    clock = chips.ManualClock()
    bus = chips.I2CBus(clock)
    bus.attach(0x53, chips.ADXL312(clock, accel_g=(0.29, 0.0, 1.0), turn_on_extra_s=0.5e-3))
    driver = ADXL312(bus, sleep=clock.sleep)
    driver.start()
    return list(driver.read_raw()), [100, 0, 345]


FINDINGS = (f1_itg3200_first_read_after_start_is_a_configured_sample,
            f2a_hmc5843_restart_after_a_program_left_another_gain,
            f2b_hmc5843_stale_power_up_measurement,
            f2c_hmc5843_first_read_with_a_non_default_gain,
            f3_adxl312_part_slower_than_typical_turn_on)


def main() -> int:
    reproduced = 0
    for finding in FINDINGS:
        got, expected = finding()
        ok = [int(v) for v in got] == expected
        reproduced += not ok
        print(f"{'fixed     ' if ok else 'REPRODUCES'} {finding.__name__}: got {list(got)}, datasheet chip "
              f"expects {expected}")
    return 1 if reproduced else 0


if __name__ == "__main__":
    raise SystemExit(main())
