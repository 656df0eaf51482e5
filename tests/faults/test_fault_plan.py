"""[sim.faults]: checked like every other key, and each fault reaches the simulated hardware at its time."""

from __future__ import annotations

import subprocess
import sys
from importlib import resources

import numpy as np
import pytest

from rig.assembly import build_sim
from rig.config import load_config, sim_faults
from rig.errors import InputError


def config(board="bsn", **faults):
    cfg = load_config()
    cfg.board = board
    cfg.sim = {"faults": faults}
    return cfg


@pytest.mark.parametrize("faults, message", [
    ({"i2c_nack_at": [1.0]}, "unknown keys ['i2c_nack_at']"),
    ({"modbus_drop_rate": 0.9}, "modbus_drop_rate = 0.9 is out of range [0, 0.5]"),
    ({"i2c_nack_s": 0}, "i2c_nack_s = 0 is out of range (0, 600]"),
    ({"bump_at_s": [-1.0]}, "must be a list of times"),
    ({"bump_at_s": 3.0}, "must be a list of times"),
    ({"modbus_delay_s": float("nan")}, "must be a finite number"),
    ({"seed": True}, "must be a whole number"),
    ({"repeat_on_resume": 1}, "must be true or false"),
    ({"i2c_nack_part": "accel", "i2c_nack_at_s": [1.0]}, "must name a part on I2C of the bsn board: ['gyro', 'mag']"),
    ({"chip_reset_part": "adc", "chip_reset_at_s": [1.0]}, "must name a chip with registers"),
    ({"adxrs453_parity_at_s": [1.0]}, "the bsn board has no ADXRS453"),
    ({"modbus_exception_code": 7}, "Modbus exception codes"),
])
def test_bad_fault_keys_are_errors_naming_the_key(faults, message):
    with pytest.raises(ValueError, match=None) as err:
        sim_faults(config(**faults))
    assert message in str(err.value) and "[sim.faults]" in str(err.value)


def test_a_bad_fault_table_in_a_rig_file_is_bad_input_without_a_traceback(tmp_path):
    text = resources.files("rig.configs").joinpath("sim.toml").read_text()
    path = tmp_path / "rig.toml"
    path.write_text(text + '\n[sim.faults]\nchip_reset_part = "gyro"\nchip_reset_at = [3.0]\n')
    res = subprocess.run([sys.executable, "-m", "rig.cli", "calibrate", "--sim", "--config", str(path),
                          "--no-progress", "--out", str(tmp_path / "s")], capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr and "unknown keys ['chip_reset_at']" in res.stderr
    assert not (tmp_path / "s").exists()


def test_faults_of_a_real_part_are_refused_when_the_rig_is_built():
    cfg = config(chip_reset_part="mag", chip_reset_at_s=[1.0])
    cfg.sim["chips"] = {"mag": "real"}
    cfg.sim["turntable"] = "fake"
    with pytest.raises(InputError, match="that part is real here"):
        build_sim(cfg)


def advance(rig, seconds):
    """Let simulated time pass with the board being read, as a session does (faults fire on bus transfers)."""
    end = rig.clock.now() + seconds
    while rig.clock.now() < end:
        rig.clock.sleep(0.01)
        for triad in rig.board.triads.values():
            try:
                triad.read_raw()
            except Exception:       # noqa: BLE001 - a fault is what is being injected
                pass


def test_an_i2c_nack_burst_starts_and_ends_on_time():
    with build_sim(config(i2c_nack_part="gyro", i2c_nack_at_s=[3.0], i2c_nack_s=0.2)) as rig:
        rig.board.start()
        bus, gyro = rig.sim.board.i2c, rig.board.triads["gyro"]
        advance(rig, 3.05 - rig.clock.now())
        assert 0x68 in bus.nacking
        with pytest.raises(Exception, match="no ACK from I2C address 0x68"):
            gyro.read_raw()
        advance(rig, 0.2)
        assert not bus.nacking
        gyro.read_raw()
        kinds = [f["fault"] for f in rig.sim.faults.fired]
    assert kinds == ["gyro (I2C 0x68) NACKs for 0.2 s", "gyro (I2C 0x68) answers again"]


def test_adxrs453_parity_and_fault_bits_reach_the_driver_as_its_errors():
    from drivers.errors import ProtocolError, SensorFault

    cfg = config("wearable", adxrs453_axis="y", adxrs453_parity_at_s=[3.0], adxrs453_parity_s=0.1,
                 adxrs453_fault_at_s=[3.5], adxrs453_fault_s=0.1, adxrs453_fault_bits=0x0040)
    with build_sim(cfg) as rig:
        rig.board.start()
        gyro_y = rig.board.triads["gyro"].gyros[1]
        advance(rig, 3.02 - rig.clock.now())
        with pytest.raises(ProtocolError, match="parity"):
            gyro_y.read_raw(True)
        advance(rig, 0.5)
        with pytest.raises(SensorFault, match="fault bits set: Q"):
            gyro_y.read_raw(True)
        advance(rig, 0.15)
        gyro_y.read_raw(True)
        gyro_y.read_raw(True)


@pytest.mark.parametrize("board, part, register", [("bsn", "gyro", "PWR_MGM"), ("bsn", "mag", "CONFIG_A"),
                                                   ("wearable", "accel", "POWER_CTL")])
def test_a_power_on_reset_is_seen_by_the_driver_as_lost_configuration(board, part, register):
    with build_sim(config(board, chip_reset_part=part, chip_reset_at_s=[3.0])) as rig:
        rig.board.start()
        driver = rig.board.triads[part]
        assert driver.configuration_lost() is None
        advance(rig, 3.05 - rig.clock.now())
        lost = driver.configuration_lost()
        assert lost is not None and register in lost and "configured 0x" in lost
        driver.start()
        assert driver.configuration_lost() is None


def test_modbus_exceptions_and_a_server_outage_reach_the_client():
    from rig.turntable.errors import CommunicationError, ModbusExceptionError

    cfg = config(modbus_exception_at_s=[3.0], modbus_exception_code=6, turntable_outage_at_s=[3.3],
                 turntable_outage_s=0.5)
    with build_sim(cfg) as rig:
        rig.board.start()
        url = rig.table.url
        advance(rig, 3.01 - rig.clock.now())
        with pytest.raises(ModbusExceptionError, match="SERVER_DEVICE_BUSY"):
            rig.table.positions()
        rig.table.positions()                                  # once only
        advance(rig, 0.3)
        with pytest.raises(CommunicationError):
            rig.table.positions()                              # down: the retries run out in 0.35 s
        advance(rig, 0.5)
        assert rig.table.positions() == pytest.approx((0.0, 0.0), abs=0.01)    # back, on the same URL
        assert rig.sim.url == url


def test_a_knock_comes_early_in_the_next_hold_and_is_taken_out_of_the_world_when_rung_out():
    cfg = config(bump_at_s=[3.0], bump_amplitude_deg=0.4)
    with build_sim(cfg) as rig:
        rig.board.start()
        advance(rig, 3.0 - rig.clock.now())
        t_due = rig.clock.now()
        advance(rig, 1.0)
        bumps = list(rig.world.bumps)
        assert len(bumps) == 1 and bumps[0].amplitude_deg == 0.4
        assert t_due + 0.8 <= bumps[0].t0 <= t_due + 2.0
        advance(rig, 4.5)
        assert rig.world.bumps == []


def test_timed_faults_happen_in_the_first_run_only_unless_repeated_on_resume():
    with build_sim(config(chip_reset_part="gyro", chip_reset_at_s=[3.0], modbus_delay_s=0.001), run=1) as rig:
        rig.board.start()
        advance(rig, 3.2 - rig.clock.now())
        assert rig.sim.faults.fired == [] and rig.board.triads["gyro"].configuration_lost() is None
        assert rig.fake_table.faults.response_delay_s == 0.001            # the link's quality holds in every run
    with build_sim(config(chip_reset_part="gyro", chip_reset_at_s=[3.0], repeat_on_resume=True), run=1) as rig:
        rig.board.start()
        advance(rig, 3.2 - rig.clock.now())
        assert rig.board.triads["gyro"].configuration_lost() is not None


def test_without_faults_nothing_is_hooked_and_a_session_is_the_same():
    with build_sim(load_config(), seed=4) as a, build_sim(config(), seed=4) as b:
        assert a.sim.faults is None and b.sim.faults is None
        assert a.sim.board.i2c.on_transfer is None
        for rig in (a, b):
            rig.board.start()
        ya = [a.board.triads["gyro"].read_raw() for _ in range(5)]
        yb = [b.board.triads["gyro"].read_raw() for _ in range(5)]
    np.testing.assert_array_equal(ya, yb)
