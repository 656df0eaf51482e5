"""Our drivers, constructed exactly as the outside testers will, against emulators written only from datasheet facts.

Each test pins a behaviour a datasheet-faithful chip has (see `datasheet_chips.py` for the sources); where the
datasheets leave a behaviour open the test runs every plausible variant.
"""

from __future__ import annotations

import numpy as np
import pytest

from drivers import ADXL312, ADXL330, ADXRS453, HMC1053, HMC5843, ITG3200, MCP3208, DriverError

import datasheet_chips as chips


def as_ints(values) -> list[int]:
    return [int(v) for v in np.atleast_1d(np.asarray(values)).ravel()]


@pytest.fixture
def clock() -> chips.ManualClock:
    return chips.ManualClock(start_s=1.0)


@pytest.fixture
def i2c(clock) -> chips.I2CBus:
    return chips.I2CBus(clock)


# ------------------------------------------------------------------------------------------------------ ADXL312 ---

def started_adxl312(clock, i2c, **chip_kwargs):
    chip = i2c.attach(0x53, chips.ADXL312(clock, **chip_kwargs))
    driver = ADXL312(i2c, sleep=clock.sleep)
    driver.start()
    return chip, driver


def test_adxl312_starts_in_measure_mode_touching_only_documented_registers(clock, i2c):
    chip, _ = started_adxl312(clock, i2c)
    assert chip.regs[chip.POWER_CTL] & 0x08, "MEASURE bit not set"
    assert chip.violations == []


@pytest.mark.parametrize("accel_g, counts", [((0.0, 0.0, 1.0), (0, 0, 345)),
                                             ((0.29, -0.58, 1.16), (100, -200, 400)),
                                             ((-1.45, 1.45, -0.0029), (-500, 500, -1))])
def test_adxl312_read_raw_gives_full_resolution_counts(clock, i2c, accel_g, counts):
    chip, driver = started_adxl312(clock, i2c, accel_g=accel_g)
    assert as_ints(driver.read_raw()) == list(counts)


def test_adxl312_first_read_after_start_is_a_real_sample(clock, i2c):
    chip, driver = started_adxl312(clock, i2c, accel_g=(0.58, 0.0, -0.29))
    assert as_ints(driver.read_raw()) == [200, 0, -100]


def test_adxl312_returns_new_data_after_one_output_period(clock, i2c):
    chip, driver = started_adxl312(clock, i2c, accel_g=(0.0, 0.0, 1.0))
    driver.read_raw()
    chip.accel_g = np.array([0.29, 0.29, 0.29])
    clock.sleep(0.05)
    assert as_ints(driver.read_raw()) == [100, 100, 100]


def test_adxl312_large_negative_value_is_sign_extended(clock, i2c):
    chip, driver = started_adxl312(clock, i2c, accel_g=(-4.06, 0.0, 0.0))
    fmt = chip.regs[chip.DATA_FORMAT]
    expected = chip.counts_for((-4.06, 0.0, 0.0))
    assert fmt & 0x08 and as_ints(driver.read_raw()) == expected and expected[0] < -1024


def test_adxl312_absent_raises_driver_error(clock, i2c):
    with pytest.raises(DriverError):
        ADXL312(i2c, sleep=clock.sleep).start()


@pytest.mark.parametrize("devid", [0xAD, 0x00, 0xE6])
def test_adxl312_wrong_devid_raises_driver_error(clock, i2c, devid):
    i2c.attach(0x53, chips.ADXL312(clock, devid=devid))
    with pytest.raises(DriverError):
        ADXL312(i2c, sleep=clock.sleep).start()


# ------------------------------------------------------------------------------------------------------ ITG3200 ---

def started_itg3200(clock, i2c, **chip_kwargs):
    chip = i2c.attach(0x68, chips.ITG3200(clock, **chip_kwargs))
    driver = ITG3200(i2c, sleep=clock.sleep)
    driver.start()
    return chip, driver


@pytest.mark.parametrize("who_am_i", [0x68, 0x69])
@pytest.mark.parametrize("status_needs_enable", [False, True])
def test_itg3200_reads_counts_at_14_375_lsb_per_dps(clock, i2c, who_am_i, status_needs_enable):
    chip, driver = started_itg3200(clock, i2c, who_am_i=who_am_i, rate_dps=(8.0, -16.0, 80.0),
                                   status_needs_enable=status_needs_enable)
    assert (chip.regs[chip.DLPF_FS] >> 3) & 3 == 3
    clock.sleep(0.02)  # two output periods at 100 Hz: see FINDINGS.md F1 for reading without this wait
    assert as_ints(driver.read_raw()) == [115, -230, 1150]
    assert chip.violations == []


def test_itg3200_new_rate_is_seen_after_a_sample_period(clock, i2c):
    chip, driver = started_itg3200(clock, i2c)
    driver.read_raw()
    chip.rate_dps = np.array([-800.0, 400.0, 0.0])
    clock.sleep(0.05)
    assert as_ints(driver.read_raw()) == [-11500, 5750, 0]


def test_itg3200_read_if_ready_gives_the_sample_once(clock, i2c):
    chip, driver = started_itg3200(clock, i2c, rate_dps=(8.0, -16.0, 80.0))
    clock.sleep(0.02)
    assert as_ints(driver.read_if_ready()) == [115, -230, 1150]
    assert driver.read_if_ready() is None             # the burst read INT_STATUS, which cleared the flag
    assert chip.violations == []


@pytest.mark.parametrize("temp_c", [-20.0, 35.0, 61.5])
def test_itg3200_temperature_uses_280_lsb_per_degc_and_minus_13200_at_35c(clock, i2c, temp_c):
    _, driver = started_itg3200(clock, i2c, temp_c=temp_c)
    assert driver.read_temperature() == pytest.approx(temp_c, abs=1 / 280)


def test_itg3200_absent_raises_driver_error(clock, i2c):
    with pytest.raises(DriverError):
        ITG3200(i2c, sleep=clock.sleep).start()


@pytest.mark.parametrize("who_am_i", [0x00, 0x52, 0xD1 ^ 0x80 ^ 0x02])
def test_itg3200_wrong_identity_raises_driver_error(clock, i2c, who_am_i):
    i2c.attach(0x68, chips.ITG3200(clock, who_am_i=who_am_i))
    with pytest.raises(DriverError):
        ITG3200(i2c, sleep=clock.sleep).start()


# ------------------------------------------------------------------------------------------------------ HMC5843 ---

def started_hmc5843(clock, i2c, **chip_kwargs):
    chip = i2c.attach(0x1E, chips.HMC5843(clock, **chip_kwargs))
    driver = HMC5843(i2c, sleep=clock.sleep)
    driver.start()
    return chip, driver


@pytest.mark.parametrize("power_up_mode", [0x01, 0x02, 0x03])
@pytest.mark.parametrize("pointer_08_to_03", [False, True])
def test_hmc5843_reads_xyz_at_1300_lsb_per_gauss(clock, i2c, power_up_mode, pointer_08_to_03):
    chip, driver = started_hmc5843(clock, i2c, field_ga=(0.2, -0.1, 0.4), power_up_mode=power_up_mode,
                                   pointer_08_to_03=pointer_08_to_03)
    assert as_ints(driver.read_raw()) == [260, -130, 520]
    assert chip.violations == []


def test_hmc5843_each_read_returns_a_new_measurement(clock, i2c):
    chip, driver = started_hmc5843(clock, i2c, field_ga=(0.2, -0.1, 0.4))
    driver.read_raw()
    chip.field_ga = np.array([-0.3, 0.5, 0.1])
    clock.sleep(0.1)
    assert as_ints(driver.read_raw()) == [-390, 650, 130]


def test_hmc5843_absent_raises_driver_error(clock, i2c):
    with pytest.raises(DriverError):
        HMC5843(i2c, sleep=clock.sleep).start()


@pytest.mark.parametrize("ident", [b"H44", b"\x00\x00\x00", b"HMC"])
def test_hmc5843_wrong_identity_raises_driver_error(clock, i2c, ident):
    i2c.attach(0x1E, chips.HMC5843(clock, ident=ident))
    with pytest.raises(DriverError):
        HMC5843(i2c, sleep=clock.sleep).start()


# ----------------------------------------------------------------------------------------------------- ADXRS453 ---

def started_adxrs453(clock, **chip_kwargs):
    chip = chips.ADXRS453(clock, **chip_kwargs)
    port = chips.SpiPort(clock, chip, mode=0, max_speed_hz=1_000_000)
    driver = ADXRS453(port, sleep=clock.sleep)
    driver.start()
    return chip, driver


@pytest.mark.parametrize("chk_hold_s", [0.055, 0.075, 0.095])
def test_adxrs453_start_up_sequence_and_rate_counts(clock, chk_hold_s):
    chip, driver = started_adxrs453(clock, rate_dps=-123.45, chk_hold_s=chk_hold_s)
    assert as_ints(driver.read_raw()) == [-9876]
    assert chip.violations == []


def test_adxrs453_waits_100_ms_when_started_at_power_on(clock):
    chip, driver = started_adxrs453(clock, powered_at=clock.now(), rate_dps=10.0)
    assert as_ints(driver.read_raw()) == [800]
    assert chip.violations == []


@pytest.mark.parametrize("temp_c", [-40.0, 45.0, 83.2])
def test_adxrs453_temperature_is_45c_plus_tem_over_5(clock, temp_c):
    _, driver = started_adxrs453(clock, temp_c=temp_c)
    assert driver.read_temperature() == pytest.approx(temp_c, abs=0.2)


def test_adxrs453_response_parity_error_raises(clock):
    chip, driver = started_adxrs453(clock)
    chip.corrupt_parity = True
    with pytest.raises(DriverError):
        driver.read_raw()


def test_adxrs453_pll_fault_raises(clock):
    chip, driver = started_adxrs453(clock)
    chip.forced_faults = 0x80
    with pytest.raises(DriverError):
        driver.read_raw()


def test_adxrs453_absent_raises(clock):
    with pytest.raises(DriverError):
        ADXRS453(chips.SpiPort(clock, None), sleep=clock.sleep).start()


def test_adxrs453_wrong_part_id_raises(clock):
    chip = chips.ADXRS453(clock, pid=0x5000)
    with pytest.raises(DriverError):
        ADXRS453(chips.SpiPort(clock, chip), sleep=clock.sleep).start()


# ---------------------------------------------------------------------------------------------- MCP3208 + analog ---

def code_centre_volts(code: int, vref: float = 3.3) -> float:
    return (code + 0.5) * vref / 4096


@pytest.mark.parametrize("hiz_level", [0, 1])
def test_mcp3208_reads_all_eight_single_ended_channels(clock, hiz_level):
    codes = [0, 1, 2048, 4095, 1234, 3000, 7, 2222]
    chip = chips.MCP3208(lambda ch: code_centre_volts(codes[ch]), hiz_level=hiz_level)
    adc = MCP3208(chips.SpiPort(clock, chip), sleep=clock.sleep)
    if hasattr(adc, "start"):
        adc.start()
    assert [adc.read(ch) for ch in range(8)] == codes
    assert chip.violations == []
    assert all(single for _, single, _ in chip.conversions)


def analog_chain(clock, volts):
    chip = chips.MCP3208(volts, vref=3.3)
    adc = MCP3208(chips.SpiPort(clock, chip), sleep=clock.sleep)
    if hasattr(adc, "start"):
        adc.start()
    return chip, adc


@pytest.mark.parametrize("accel_g", [(0.0, 0.0, 1.0), (-2.5, 1.25, 0.5)])
def test_adxl330_read_raw_gives_the_adc_codes_of_channels_0_1_2(clock, accel_g):
    model = chips.ADXL330Model(supply_v=3.3, accel_g=accel_g)
    chip, adc = analog_chain(clock, lambda ch: model.volts(ch) if ch < 3 else 0.0)
    driver = ADXL330(adc, sleep=clock.sleep)
    driver.start()
    expected = [chip.code(ch) for ch in range(3)]
    assert expected == [int(np.floor(4096 * (0.5 + 0.1 * a))) for a in accel_g]
    assert as_ints(driver.read_raw()) == [code - 2048 for code in expected]


def test_hmc1053_read_raw_gives_the_adc_codes_of_channels_3_4_5(clock):
    model = chips.HMC1053Model()
    chip, adc = analog_chain(clock, lambda ch: model.volts(ch - 3) if 3 <= ch < 6 else 0.0)
    driver = HMC1053(adc, sleep=clock.sleep)
    driver.start()
    assert as_ints(driver.read_raw()) == [chip.code(ch) - 2048 for ch in (3, 4, 5)]




# ------------------------------------------------------------------------------------------- more behaviours ---

class StuckMiso:
    """An SPI slot with nothing fitted and a pull-up: every byte reads 0xFF."""

    def transfer(self, tx, port):
        return [0xFF] * len(tx)


@pytest.mark.parametrize("range_g, accel_g, counts", [(1.5, (-1.45, 1.45, 0.29), [-500, 500, 100]),
                                                      (12, (-11.6, 8.7, 0.29), [-4000, 3000, 100])])
def test_adxl312_full_resolution_in_two_ranges(clock, i2c, range_g, accel_g, counts):
    chip = i2c.attach(0x53, chips.ADXL312(clock, accel_g=accel_g))
    driver = ADXL312(i2c, range_g=range_g, sleep=clock.sleep)
    driver.start()
    assert as_ints(driver.read_raw()) == counts


def test_adxl312_warm_restart_after_a_program_left_another_format(clock, i2c):
    i2c.attach(0x53, chips.ADXL312(clock, accel_g=(0.29, 0.0, 1.0)))
    i2c.write_byte_data(0x53, 0x31, 0x04)  # 10-bit, left-justified, +-1.5 g
    i2c.write_byte_data(0x53, 0x2D, 0x08)
    clock.sleep(0.5)
    driver = ADXL312(i2c, sleep=clock.sleep)
    driver.start()
    assert as_ints(driver.read_raw()) == [100, 0, 345]


def test_adxl312_stream_fifo_drains_one_entry_per_burst(clock, i2c):
    chip, driver = started_adxl312(clock, i2c, accel_g=(0.29, -0.58, 1.0))
    driver.configure_fifo(16)
    clock.sleep(0.0951)
    samples = driver.read_fifo()
    assert len(samples) == 9 and all(list(s) == [100, -200, 345] for s in samples)
    assert chip.violations == []


def test_itg3200_steady_state_temperature_and_rate_together(clock, i2c):
    chip, driver = started_itg3200(clock, i2c, rate_dps=(-1000.0, 0.0, 2000.0), temp_c=50.0)
    clock.sleep(0.02)
    assert as_ints(driver.read_raw()) == [-14375, 0, 28750]
    assert driver.read_temperature() == pytest.approx(50.0, abs=1 / 280)


def test_hmc5843_second_gain_after_the_first_sample_has_passed(clock, i2c):
    i2c.attach(0x1E, chips.HMC5843(clock, field_ga=(0.2, -0.1, 0.4)))
    driver = HMC5843(i2c, gain=970, sleep=clock.sleep)
    driver.start()
    clock.sleep(0.25)  # see FINDINGS.md F2 for reading at once
    assert as_ints(driver.read_raw()) == [194, -97, 388]


def test_hmc5843_overflow_marker_raises(clock, i2c):
    chip, driver = started_hmc5843(clock, i2c, field_ga=(0.2, -0.1, 0.4))
    chip.field_ga = np.array([0.2, 1.7, 0.4])  # 1.7 Ga * 1300 > 2047 -> -4096 [D p.15]
    clock.sleep(0.2)
    with pytest.raises(DriverError):
        driver.read_raw()


def test_adxrs453_restart_without_power_cycle(clock):
    chip, _ = started_adxrs453(clock, rate_dps=10.0)
    clock.sleep(1.0)
    driver = ADXRS453(chips.SpiPort(clock, chip, mode=0, max_speed_hz=1_000_000), sleep=clock.sleep)
    driver.start()
    assert as_ints(driver.read_raw()) == [800]
    assert chip.violations == []


def test_adxrs453_miso_stuck_high_raises(clock):
    with pytest.raises(DriverError):
        ADXRS453(chips.SpiPort(clock, StuckMiso()), sleep=clock.sleep).start()


def test_adxrs453_fault_after_start_raises(clock):
    chip, driver = started_adxrs453(clock)
    chip.forced_faults = 0x04  # CST
    with pytest.raises(DriverError):
        driver.read_raw()


def test_mcp3208_miso_stuck_high_raises(clock):
    adc = MCP3208(chips.SpiPort(clock, StuckMiso()), sleep=clock.sleep)
    with pytest.raises(DriverError):
        adc.read(0)


def test_adxl330_with_no_converter_driving_miso_raises(clock):
    adc = MCP3208(chips.SpiPort(clock, None), sleep=clock.sleep)  # MISO pulled low: every code 0
    with pytest.raises(DriverError):
        ADXL330(adc, sleep=clock.sleep).start()


def test_hmc1053_with_strap_driver_returns_set_minus_reset(clock):
    model = chips.HMC1053Model()
    chip, adc = analog_chain(clock, lambda ch: model.volts(ch - 3) if 3 <= ch < 6 else 0.0)
    driver = HMC1053(adc, set_reset=lambda polarity: model.pulse(polarity > 0), sleep=clock.sleep)
    driver.start()
    model.pulse(True)
    set_codes = [chip.code(ch) for ch in (3, 4, 5)]
    model.pulse(False)
    reset_codes = [chip.code(ch) for ch in (3, 4, 5)]
    assert as_ints(driver.read_raw()) == [s - r for s, r in zip(set_codes, reset_codes)]
    assert [s - r for s, r in zip(set_codes, reset_codes)] == [164, -82, 328]
