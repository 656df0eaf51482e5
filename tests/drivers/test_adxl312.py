"""ADXL312 byte-level tests: start-up writes, I2C and SPI framing (R/MB bits), sign extension, FIFO, faults."""

from __future__ import annotations

import errno

import pytest

from drivers import ADXL312, DeviceAbsent, FifoOverrun, SensorFault, WrongIdentity
from tests.drivers.conftest import expected_protocol, nack

A = 0x53
START_I2C_CONFIG = [
    ("r", A, 0x00, 0xE5),
    ("w", A, 0x2D, 0x00, None),      # POWER_CTL standby while configuring
    ("w", A, 0x31, 0x0B, None),      # DATA_FORMAT FULL_RES | range +-12 g
    ("w", A, 0x2C, 0x0A, None),      # BW_RATE 100 Hz
    ("w", A, 0x2E, 0x00, None),      # INT_ENABLE off
    ("w", A, 0x38, 0x00, None),      # FIFO_CTL bypass
    ("w", A, 0x2D, 0x08, None),      # POWER_CTL MEASURE
]
FIRST_SAMPLE = [("r", A, 0x30, 0x82), ("rb", A, 0x32, 6, [0] * 6)]   # wait for DATA_READY, drop the sample
START_I2C = START_I2C_CONFIG + FIRST_SAMPLE


def started_i2c(bus, sleeps, **kw):
    accel = ADXL312(bus, sleep=sleeps, **kw)
    accel.start()
    return accel


def test_i2c_start_up_sequence_and_turn_on_wait(sleeps):
    with expected_protocol("i2c", START_I2C) as bus:
        started_i2c(bus, sleeps)
    assert sleeps == [pytest.approx(1 / 100 + 1.1e-3)]


def test_range_and_rate_codes_reach_the_registers(sleeps):
    steps = [("r", A, 0x00, 0xE5), ("w", A, 0x2D, 0x00, None), ("w", A, 0x31, 0x08, None),
             ("w", A, 0x2C, 0x0F, None), ("w", A, 0x2E, 0x00, None), ("w", A, 0x38, 0x00, None),
             ("w", A, 0x2D, 0x08, None)] + FIRST_SAMPLE
    with expected_protocol("i2c", steps) as bus:
        started_i2c(bus, sleeps, range_g=1.5, rate_hz=3200)


def test_start_waits_for_the_first_conversion_beyond_the_typical_turn_on(sleeps):
    """The turn-on time is typical only: a slower part has no data yet, so DATA_READY is polled."""
    with expected_protocol("i2c", START_I2C_CONFIG + [("r", A, 0x30, 0x02)] * 2 + FIRST_SAMPLE) as bus:
        started_i2c(bus, sleeps)
    assert sleeps == [pytest.approx(1 / 100 + 1.1e-3), 2.5e-3, 2.5e-3]


def test_no_conversion_after_measure_is_a_bounded_sensor_fault(sleeps):
    with expected_protocol("i2c", START_I2C_CONFIG + [("r", A, 0x30, 0x02)] * 6) as bus:
        with pytest.raises(SensorFault, match="DATA_READY not set"):
            started_i2c(bus, sleeps)


def test_spi_start_up_uses_read_bit_and_plain_write_address(sleeps):
    steps = [("x", (0x80, 0x00), [0x00, 0xE5])] + [
        ("x", (reg, value), [0x00, 0x00]) for _, _, reg, value, _ in START_I2C_CONFIG[1:]] + [
        ("x", (0xB0, 0x00), [0x00, 0x80]), ("x", (0xF2, 0, 0, 0, 0, 0, 0), [0x00] * 7)]
    with expected_protocol("spi", steps) as spi:
        ADXL312(spi, sleep=sleeps).start()


def test_spi_burst_read_sets_read_and_multibyte_bits(sleeps):
    steps = [("x", (0xF2, 0, 0, 0, 0, 0, 0), [0x00, 0x59, 0x01, 0xA7, 0xFE, 0x00, 0x00])]
    with expected_protocol("spi", steps) as spi:
        assert ADXL312(spi, sleep=sleeps).read_raw() == (345, -345, 0)


@pytest.mark.parametrize("devid", [0xE6, 0xAD])
def test_wrong_devid_is_rejected_naming_register(devid, sleeps):
    with expected_protocol("i2c", [("r", A, 0x00, devid)]) as bus:
        with pytest.raises(WrongIdentity, match=r"ADXL312 at I2C address 0x53, register 0x00 DEVID"):
            ADXL312(bus, sleep=sleeps).start()


def test_i2c_nack_is_device_absent_with_cause(sleeps):
    with expected_protocol("i2c", [("r", A, 0x00, nack())]) as bus:
        with pytest.raises(DeviceAbsent, match="0x53") as info:
            ADXL312(bus, sleep=sleeps).start()
    assert info.value.__cause__.errno == errno.EREMOTEIO


@pytest.mark.parametrize("floating", [0x00, 0xFF])
def test_spi_floating_miso_is_device_absent(floating, sleeps):
    with expected_protocol("spi", [("x", (0x80, 0x00), [floating, floating])]) as spi:
        with pytest.raises(DeviceAbsent, match="MISO"):
            ADXL312(spi, cs="spidev0.1", sleep=sleeps).start()


@pytest.mark.parametrize("range_g, raw, expected", [
    (12, [0xFF, 0x1F, 0x00, 0x10, 0xFF, 0x0F], (-1, -4096, 4095)),      # 13-bit, upper bits not extended
    (12, [0xFF, 0xFF, 0x00, 0xF0, 0x01, 0x00], (-1, -4096, 1)),         # 13-bit, already sign-extended
    (1.5, [0xFF, 0x03, 0x00, 0x02, 0xFF, 0x01], (-1, -512, 511)),       # 10-bit
    (3, [0x00, 0x04, 0xFF, 0x03, 0xFF, 0x07], (-1024, 1023, -1)),       # 11-bit
    (6, [0x00, 0x08, 0xFF, 0x07, 0x59, 0x01], (-2048, 2047, 345)),      # 12-bit
])
def test_little_endian_sign_extension_per_range(range_g, raw, expected, sleeps):
    with expected_protocol("i2c", [("rb", A, 0x32, 6, raw)]) as bus:
        assert ADXL312(bus, range_g=range_g, sleep=sleeps).read_raw() == expected


def test_read_error_names_data_register(sleeps):
    with expected_protocol("i2c", [("rb", A, 0x32, 6, nack())]) as bus:
        with pytest.raises(DeviceAbsent, match=r"register 0x32 DATAX0"):
            ADXL312(bus, sleep=sleeps).read_raw()


@pytest.mark.parametrize("kw, match", [({"range_g": 16}, r"allowed: 1.5, 3, 6, 12 g"),
                                       ({"rate_hz": 150}, r"allowed: 6.25, 12.5, 25.*3200 Hz")])
def test_unsupported_settings_list_allowed_values(kw, match, sleeps):
    with pytest.raises(ValueError, match=match):
        ADXL312(object(), sleep=sleeps, **kw)


def test_set_range_after_start_writes_data_format_and_changes_decoding(sleeps):
    with expected_protocol("i2c", START_I2C + [("w", A, 0x31, 0x08, None), ("rb", A, 0x32, 6,
                                                                          [0xFF, 0x03, 0, 0, 0, 0])]) as bus:
        accel = started_i2c(bus, sleeps)
        accel.set_range(1.5)
        assert accel.read_raw() == (-1, 0, 0)


def test_data_ready_reads_int_source_bit7(sleeps):
    with expected_protocol("i2c", [("r", A, 0x30, 0x82), ("r", A, 0x30, 0x02)]) as bus:
        accel = ADXL312(bus, sleep=sleeps)
        assert accel.data_ready() is True
        assert accel.data_ready() is False


def test_configure_fifo_stream_mode_with_watermark(sleeps):
    steps = [("w", A, 0x2D, 0x00, None), ("w", A, 0x38, 0x80 | 20, None), ("w", A, 0x2E, 0x03, None),
             ("w", A, 0x2D, 0x08, None)]
    with expected_protocol("i2c", steps) as bus:
        ADXL312(bus, sleep=sleeps).configure_fifo(20)


@pytest.mark.parametrize("watermark", [0, 32, 2.5])
def test_bad_watermark_rejected(watermark, sleeps):
    with pytest.raises(ValueError, match="allowed: 1..31"):
        ADXL312(object(), sleep=sleeps).configure_fifo(watermark)


def test_read_fifo_drains_entries_in_6_byte_bursts(sleeps):
    steps = [("r", A, 0x30, 0x82), ("r", A, 0x39, 0x83),           # FIFO_TRIG bit set, 3 entries
             ("rb", A, 0x32, 6, [1, 0, 2, 0, 3, 0]),
             ("rb", A, 0x32, 6, [0xFF, 0xFF, 0, 0, 0x59, 0x01]),
             ("rb", A, 0x32, 6, [0, 0, 0, 0, 0, 0])]
    with expected_protocol("i2c", steps) as bus:
        assert ADXL312(bus, sleep=sleeps).read_fifo() == [(1, 2, 3), (-1, 0, 345), (0, 0, 0)]


def test_fifo_overrun_raises_after_draining(sleeps):
    steps = [("r", A, 0x30, 0x83), ("r", A, 0x39, 2),
             ("rb", A, 0x32, 6, [1, 0, 0, 0, 0, 0]), ("rb", A, 0x32, 6, [2, 0, 0, 0, 0, 0])]
    with expected_protocol("i2c", steps) as bus:
        with pytest.raises(FifoOverrun, match=r"ADXL312 at I2C address 0x53.*overrun") as info:
            ADXL312(bus, sleep=sleeps).read_fifo()
    assert info.value.samples == [(1, 0, 0), (2, 0, 0)]


def test_settings_snapshot_scale_in_m_s2(sleeps):
    s = ADXL312(object(), range_g=6, rate_hz=400, sleep=sleeps).settings()
    assert (s["range"], s["rate_hz"], s["interface"]) == (6.0, 400.0, "i2c")
    assert s["scale"] == pytest.approx(0.0284, rel=2e-3)


def le16(value: int) -> list[int]:
    return list(value.to_bytes(2, "little", signed=True))


def self_test_steps(z_off: int, z_on: int, samples: int = 2) -> list:
    return ([("w", A, 0x2D, 0x00, None), ("w", A, 0x31, 0x0B, None), ("w", A, 0x2C, 0x0A, None),
             ("w", A, 0x2D, 0x08, None)]
            + [("rb", A, 0x32, 6, [0, 0, 0, 0] + le16(z_off))] * samples
            + [("w", A, 0x31, 0x8B, None)]
            + [("rb", A, 0x32, 6, [0, 0, 0, 0] + le16(z_on))] * samples
            + [("w", A, 0x31, 0x08, None), ("w", A, 0x2C, 0x09, None)])


def test_self_test_z_change_in_mg_and_restores_settings(sleeps):
    with expected_protocol("i2c", self_test_steps(345, 345 + 345)) as bus:   # +1 g change
        accel = ADXL312(bus, range_g=1.5, rate_hz=50, sleep=sleeps)
        assert accel.self_test(samples=2) == pytest.approx(1000.0)
    assert sleeps[0] == pytest.approx(0.05) and len(sleeps) == 1 + 2 + 1 + 2 + 1


@pytest.mark.parametrize("z_on", [345 + 50, 345 - 400, 345 + 1300])
def test_self_test_out_of_limits_is_sensor_fault(z_on, sleeps):
    with expected_protocol("i2c", self_test_steps(345, z_on)) as bus:
        with pytest.raises(SensorFault, match=r"DATA_FORMAT: self-test Z change -?\d+ mg outside 300..3400 mg"):
            ADXL312(bus, range_g=1.5, rate_hz=50, sleep=sleeps).self_test(samples=2)
