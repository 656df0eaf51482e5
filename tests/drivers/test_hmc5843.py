"""HMC5843 byte-level tests: identity, init writes, X/Y/Z order, -4096 saturation, RDY."""

from __future__ import annotations

import pytest

from drivers import HMC5843, DeviceAbsent, SensorFault, SensorSaturated, WrongIdentity
from tests.drivers.conftest import expected_protocol, nack

A = 0x1E
INIT = [("rb", A, 0x0A, 3, list(b"H43")),
        ("w", A, 0x00, 0x10, None),     # CONFIG_A: DO = 4 (10 Hz), MS = normal
        ("w", A, 0x01, 0x20, None),     # CONFIG_B: GN = 1 (1300 LSB/Ga)
        ("w", A, 0x02, 0x00, None)]     # MODE continuous


def test_init_sequence_waits_first_sample_and_drops_it(sleeps):
    """Timed, not RDY-driven: 2/f to the first conversion (dropped: it may use the old gain), then 1/f more."""
    steps = INIT + [("r", A, 0x09, 0x00), ("r", A, 0x09, 0x01), ("rb", A, 0x03, 6, [0] * 6)]
    with expected_protocol("i2c", steps) as bus:
        HMC5843(bus, sleep=sleeps).start()
    assert sleeps == pytest.approx([0.22, 0.02, 0.11])


def test_a_stale_rdy_from_an_earlier_run_does_not_shortcut_the_settling(sleeps):
    """RDY stays set across a restart (reading never clears it): the waits must happen anyway."""
    steps = INIT + [("r", A, 0x09, 0x01), ("rb", A, 0x03, 6, [0] * 6)]
    with expected_protocol("i2c", steps) as bus:
        HMC5843(bus, sleep=sleeps).start()
    assert sum(sleeps) == pytest.approx(0.33)


def test_rate_and_gain_codes(sleeps):
    steps = [INIT[0], ("w", A, 0x00, 0x18, None), ("w", A, 0x01, 0xE0, None), INIT[3],
             ("r", A, 0x09, 0x01), ("rb", A, 0x03, 6, [0] * 6)]
    with expected_protocol("i2c", steps) as bus:
        mag = HMC5843(bus, rate_hz=50, gain=280, sleep=sleeps)
        mag.start()
    assert mag.settings()["scale"] == pytest.approx(100 / 280)


@pytest.mark.parametrize("ident", [b"H44", b"\x00\x00\x00", b"H43"[::-1]])
def test_wrong_identity(ident, sleeps):
    with expected_protocol("i2c", [("rb", A, 0x0A, 3, list(ident))]) as bus:
        with pytest.raises(WrongIdentity, match=r"HMC5843 at I2C address 0x1E, register 0x0A ID_A"):
            HMC5843(bus, sleep=sleeps).start()


def test_absent(sleeps):
    with expected_protocol("i2c", [("rb", A, 0x0A, 3, nack())]) as bus:
        with pytest.raises(DeviceAbsent, match="0x1E"):
            HMC5843(bus, sleep=sleeps).start()


def test_no_data_ready_is_bounded_fault(sleeps):
    with expected_protocol("i2c", INIT + [("r", A, 0x09, 0x00)] * 150) as bus:
        with pytest.raises(SensorFault, match=r"0x09 STATUS: RDY not set after 150 polls"):
            HMC5843(bus, sleep=sleeps).start()


def test_read_raw_is_x_y_z_big_endian(sleeps):
    with expected_protocol("i2c", [("rb", A, 0x03, 6, [0x01, 0x00, 0xFF, 0x38, 0x07, 0xFF])]) as bus:
        assert HMC5843(bus, sleep=sleeps).read_raw() == (256, -200, 2047)


@pytest.mark.parametrize("raw, axis, reg", [([0xF0, 0x00, 0, 0, 0, 0], "X", "0x03 DATA_X_MSB"),
                                            ([0, 0, 0xF0, 0x00, 0, 0], "Y", "0x05 DATA_Y_MSB"),
                                            ([0, 0, 0, 0, 0xF0, 0x00], "Z", "0x07 DATA_Z_MSB")])
def test_overflow_marker_raises_naming_axis(raw, axis, reg, sleeps):
    with expected_protocol("i2c", [("rb", A, 0x03, 6, raw)]) as bus:
        with pytest.raises(SensorSaturated, match=rf"register {reg}: {axis} axis reads -4096"):
            HMC5843(bus, sleep=sleeps).read_raw()


def test_data_ready_uses_status_rdy(sleeps):
    with expected_protocol("i2c", [("r", A, 0x09, 0x03), ("r", A, 0x09, 0x02)]) as bus:
        mag = HMC5843(bus, sleep=sleeps)
        assert mag.data_ready() is True
        assert mag.data_ready() is False


@pytest.mark.parametrize("kw, match", [({"rate_hz": 75}, r"allowed: 0.5, 1, 2, 5, 10, 20, 50 Hz"),
                                       ({"gain": 1090}, r"allowed: 1620, 1300, 970, 780, 530, 460, 390, 280")])
def test_unsupported_settings(kw, match, sleeps):
    with pytest.raises(ValueError, match=match):
        HMC5843(object(), sleep=sleeps, **kw)


def test_set_gain_after_start_writes_config_b(sleeps):
    steps = INIT + [("r", A, 0x09, 0x01), ("rb", A, 0x03, 6, [0] * 6), ("w", A, 0x01, 0x80, None),
                    ("r", A, 0x09, 0x01), ("rb", A, 0x03, 6, [0] * 6)]
    with expected_protocol("i2c", steps) as bus:
        mag = HMC5843(bus, sleep=sleeps)
        mag.start()
        mag.set_gain(530)
