"""ITG-3200 byte-level tests: start-up writes with plain register addresses, PLL-ready wait, rates, decoding."""

from __future__ import annotations

import pytest

import numpy as np

from drivers import ITG3200, DeviceAbsent, SensorFault, WrongIdentity
from drivers.itg3200 import exact_rates
from fixtures.buses import FakeSMBus
from fixtures.chips import ITG3200Emulator
from fixtures.sources import ConstantSource
from rig.clock import SimClock
from tests.drivers.conftest import expected_protocol, nack

A = 0x68


def start_steps(who=0x68, dlpf_fs=0x1B, divider=9, status=(0x04,)):
    steps = [("r", A, 0x00, who),
             ("w", A, 0x3E, 0x80, None),          # PWR_MGM H_RESET
             ("w", A, 0x17, 0x35, None),          # INT_CFG latch | any-read clear | ITG_RDY_EN | RAW_RDY_EN
             ("w", A, 0x3E, 0x01, None),          # PWR_MGM CLK_SEL = PLL with X gyro
             ("w", A, 0x16, dlpf_fs, None),       # DLPF_FS FS_SEL=3 | DLPF_CFG
             ("w", A, 0x15, divider, None)]       # SMPLRT_DIV
    steps += [("r", A, 0x1A, s) for s in status]
    return steps


FIRST_SAMPLE = [("r", A, 0x1A, 0x01), ("rb", A, 0x1D, 6, [0x7F] * 6)]   # wait for data, drop it


def test_start_up_sequence_plain_addresses(sleeps):
    with expected_protocol("i2c", start_steps() + [("r", A, 0x16, 0x1B)] + FIRST_SAMPLE) as bus:
        ITG3200(bus, sleep=sleeps).start()
    assert sleeps == [1.5e-3]


def test_start_waits_for_a_sample_taken_with_the_new_settings(sleeps):
    """ITG_RDY is only the PLL: the data registers may hold pre-configuration values until RAW_DATA_RDY."""
    waiting = [("r", A, 0x1A, 0x00)] * 3
    with expected_protocol("i2c", start_steps() + [("r", A, 0x16, 0x1B)] + waiting + FIRST_SAMPLE) as bus:
        ITG3200(bus, sleep=sleeps).start()
    assert sleeps == [1.5e-3, 2.5e-3, 2.5e-3, 2.5e-3]


def test_no_data_after_configuring_is_a_bounded_sensor_fault(sleeps):
    steps = start_steps() + [("r", A, 0x16, 0x1B)] + [("r", A, 0x1A, 0x00)] * 29
    with expected_protocol("i2c", steps) as bus:
        with pytest.raises(SensorFault, match="RAW_DATA_RDY not set"):
            ITG3200(bus, sleep=sleeps).start()


def test_who_am_i_with_ad0_high_is_accepted(sleeps):
    steps = [(op, 0x69, *rest) for op, _, *rest in start_steps(who=0x69) + [("r", A, 0x16, 0x1B)] + FIRST_SAMPLE]
    with expected_protocol("i2c", steps) as bus:
        ITG3200(bus, address=0x69, sleep=sleeps).start()


@pytest.mark.parametrize("who", [0x00, 0xFF, 0x2A])
def test_wrong_who_am_i(who, sleeps):
    with expected_protocol("i2c", [("r", A, 0x00, who)]) as bus:
        with pytest.raises(WrongIdentity, match=rf"0x68, register 0x00 WHO_AM_I: read 0x{who:02X}"):
            ITG3200(bus, sleep=sleeps).start()


def test_absent_chip(sleeps):
    with expected_protocol("i2c", [("r", A, 0x00, nack())]) as bus:
        with pytest.raises(DeviceAbsent, match="ITG-3200 at I2C address 0x68"):
            ITG3200(bus, sleep=sleeps).start()


def test_pll_ready_wait_polls_until_set(sleeps):
    with expected_protocol("i2c", start_steps(status=(0x00, 0x01, 0x05)) + [("r", A, 0x16, 0x1B)]
                           + FIRST_SAMPLE) as bus:
        ITG3200(bus, sleep=sleeps).start()
    assert sleeps == [1.5e-3, 5e-3, 5e-3]


def test_pll_never_ready_is_bounded_sensor_fault(sleeps):
    with expected_protocol("i2c", start_steps(status=(0x00,) * 20)) as bus:
        with pytest.raises(SensorFault, match=r"register 0x1A INT_STATUS: ITG_RDY"):
            ITG3200(bus, sleep=sleeps).start()
    assert len(sleeps) == 1 + 20


def test_dlpf_fs_read_back_mismatch_fails_start(sleeps):
    with expected_protocol("i2c", start_steps() + [("r", A, 0x16, 0x03)]) as bus:
        with pytest.raises(SensorFault, match=r"0x16 DLPF_FS: read back 0x03, wrote 0x1B"):
            ITG3200(bus, sleep=sleeps).start()


def test_8khz_internal_rate_with_256hz_filter(sleeps):
    steps = start_steps(dlpf_fs=0x18, divider=19) + [("r", A, 0x16, 0x18)] + FIRST_SAMPLE
    with expected_protocol("i2c", steps) as bus:
        ITG3200(bus, rate_hz=400, dlpf_hz=256, sleep=sleeps).start()


def test_exact_rates_follow_internal_clock():
    assert exact_rates(42)[100] == 9 and exact_rates(42)[4] == 249
    assert 400 not in exact_rates(42) and 3 not in exact_rates(42)
    assert exact_rates(256)[400] == 19 and exact_rates(256)[8000] == 0


@pytest.mark.parametrize("kw, match", [
    ({"rate_hz": 400}, r"sample rate with DLPF 42 Hz 400 Hz; allowed: 1000, 500, 250, 200, 125, 100, .*, 4 Hz"),
    ({"rate_hz": 300, "dlpf_hz": 256}, r"allowed: 8000, 4000, .*400.*32 Hz"),
    ({"dlpf_hz": 50}, r"low-pass bandwidth 50 Hz; allowed: 256, 188, 98, 42, 20, 10, 5 Hz"),
])
def test_unsupported_rate_or_filter_lists_allowed(kw, match, sleeps):
    with pytest.raises(ValueError, match=match):
        ITG3200(object(), sleep=sleeps, **kw)


def test_read_raw_big_endian_burst_from_gyro_xout_h(sleeps):
    with expected_protocol("i2c", [("rb", A, 0x1D, 6, [0x01, 0x02, 0xFF, 0xFE, 0x80, 0x00])]) as bus:
        assert ITG3200(bus, sleep=sleeps).read_raw() == (258, -2, -32768)


@pytest.mark.parametrize("raw, celsius", [(-13200, 35.0), (-23000, 0.0), (5000, 100.0)])
def test_temperature_formula(raw, celsius, sleeps):
    with expected_protocol("i2c", [("rb", A, 0x1A, 3, [0x00, *raw.to_bytes(2, "big", signed=True)])]) as bus:
        assert ITG3200(bus, sleep=sleeps).read_temperature() == pytest.approx(celsius)


def test_a_temperature_read_does_not_hide_an_unread_sample(sleeps):
    """Any read clears RAW_DATA_RDY: the temperature burst reads INT_STATUS too, and the sample it announced
    is still reported ready by the next poll (once), whether that is `read_if_ready` or `data_ready`."""
    sample = [0x00, 0x00, 0x00, 0x01, 0x02, 0xFF, 0xFE, 0x80, 0x00]
    steps = [("rb", A, 0x1A, 3, [0x01, 0xCC, 0x70]), ("rb", A, 0x1A, 9, sample), ("rb", A, 0x1A, 9, sample),
             ("rb", A, 0x1A, 3, [0x01, 0xCC, 0x70]), ("r", A, 0x1A, 0x00), ("r", A, 0x1A, 0x00),
             ("rb", A, 0x1A, 3, [0x00, 0xCC, 0x70]), ("rb", A, 0x1A, 9, sample)]
    with expected_protocol("i2c", steps) as bus:
        gyro = ITG3200(bus, sleep=sleeps)
        assert gyro.read_temperature() == pytest.approx(35.0)
        assert gyro.read_if_ready() == (258, -2, -32768)
        assert gyro.read_if_ready() is None
        gyro.read_temperature()
        assert gyro.data_ready() is True
        assert gyro.data_ready() is False
        gyro.read_temperature()
        assert gyro.read_if_ready() is None


def test_data_ready_and_rate_change(sleeps):
    steps = start_steps() + [("r", A, 0x16, 0x1B)] + FIRST_SAMPLE + [("r", A, 0x1A, 0x01), ("r", A, 0x1A, 0x00),
                             ("w", A, 0x15, 19, None)]
    with expected_protocol("i2c", steps) as bus:
        gyro = ITG3200(bus, sleep=sleeps)
        gyro.start()
        assert gyro.data_ready() is True
        assert gyro.data_ready() is False
        gyro.set_rate(50)
    assert gyro.settings()["rate_hz"] == 50.0


def test_read_if_ready_is_one_burst_from_int_status(sleeps):
    """Flag and sample in one 9-byte auto-increment burst: the sample when RAW_DATA_RDY is set, else None."""
    ready = [0x01, 0x00, 0x00, 0x01, 0x02, 0xFF, 0xFE, 0x80, 0x00]
    steps = [("rb", A, 0x1A, 9, ready), ("rb", A, 0x1A, 9, [0x04] + ready[1:])]
    with expected_protocol("i2c", steps) as bus:
        gyro = ITG3200(bus, sleep=sleeps)
        assert gyro.read_if_ready() == (258, -2, -32768)
        assert gyro.read_if_ready() is None           # ITG_RDY alone is not a sample


def test_settings_scale_rad_per_s(sleeps):
    s = ITG3200(object(), sleep=sleeps).settings()
    assert s["scale"] == pytest.approx(1.214142e-3, rel=1e-6)   # kernel 1 214 142 nrad/s per LSB


@pytest.mark.parametrize("between", ["read_temperature", "configuration_lost"])
def test_reads_between_a_sample_and_its_poll_do_not_hide_it(between):
    """On the emulated chip: a sample arrives, a temperature read or the configuration read-back happens before
    the sampler's poll (any read clears RAW_DATA_RDY), and the poll still gets that sample, once."""
    clock = SimClock()
    bus = FakeSMBus(1)
    bus.attach(A, ITG3200Emulator(ConstantSource(np.radians([10.0, 0.0, 0.0])), clock))
    gyro = ITG3200(bus, sleep=clock.sleep)
    gyro.start()
    while gyro.read_if_ready() is None:
        clock.sleep(0.001)
    clock.sleep(1.0 / gyro.rate_hz)
    getattr(gyro, between)()
    sample = gyro.read_if_ready()
    assert sample is not None and sample[0] == pytest.approx(10.0 * 14.375, abs=2)
    assert gyro.read_if_ready() is None
