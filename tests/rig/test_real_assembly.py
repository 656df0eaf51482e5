"""The real rig's assembly on the real clock, with the buses opened by injected openers (here: emulated
chips) and the turntable at a URL (here: the fake turntable on loopback, also on real time); and mixed
hardware in the loop, real or fake chosen per part and for the table by the configuration's [sim] section."""

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from drivers.gpio import open_set_reset_line
from fixtures.followed_table import FollowedTable
from fixtures.gpio import FakeGpiod
from fixtures.simrig import SimulatedHardware
from fixtures.turntable import FakeTurntable, TurntableServer
from rig.schedule import Orientation, schedule_rotations
from procedures.session import record
from rig.assembly import HardwareUnavailable, build_real, build_sim
from rig.clock import RealClock
from rig.config import load_config
from tests.procedures.test_procedure import MemoryStore

SCHEDULE = [Orientation(10, 0), Orientation(80, 60), Orientation(150, -40), Orientation(60, 140)]


def test_build_real_runs_a_short_session_on_real_time():
    config = load_config()
    config.schedule.hold_s = 0.3
    config.turntable.speed_dps, config.turntable.accel_dps2 = 400.0, 2000.0
    with SimulatedHardware(config, RealClock(), seed=4) as hw:
        config.turntable.url = hw.url
        opened = []

        def open_i2c(n):
            opened.append(("i2c", n))
            return hw.i2c

        def open_spi(bus, cs, mode, hz):
            opened.append(("spi", bus, cs, mode))
            return hw.spi(cs, mode, hz)

        with build_real(config, open_i2c=open_i2c, open_spi=open_spi) as rig:
            assert isinstance(rig.clock, RealClock) and rig.truth_fn is None
            rig.board.start()
            store = MemoryStore()
            record(rig, store, SCHEDULE)
            status = rig.table.status()
    assert ("i2c", 1) in opened and ("spi", 0, 0, 0) in opened
    assert sorted(store.holds) == [0, 1, 2, 3]
    for hold in store.holds.values():
        assert hold["t"].size == 30
        assert not np.isnan(hold["samples"]["gyro"]).any()
    assert all("ENABLED" not in ax.flags for ax in status.axes)


# --- mixed hardware in the loop: real or fake per part, from the configuration ([sim]) ---------------------



def fast_config(board="bsn", **sim):
    config = load_config()
    config.board = board
    config.schedule.hold_s = 0.3
    config.turntable.speed_dps, config.turntable.accel_dps2 = 400.0, 2000.0
    config.sim = dict(sim)
    return config


def test_real_chips_against_the_fake_table_served_in_this_process():
    config = fast_config(turntable="fake")
    bench = SimulatedHardware(config, RealClock(), seed=4)        # stands in for the chips on the bench
    with build_real(config, open_i2c=lambda n: bench.i2c, open_spi=lambda b, cs, m, hz: bench.spi(cs, m, hz)) as rig:
        assert rig.fake_table is not None and rig.truth_fn is None and isinstance(rig.clock, RealClock)
        assert rig.table.url.startswith("tcp://127.0.0.1:") and rig.table.url != config.turntable.url
        rig.board.start()
        store = MemoryStore()
        record(rig, store, SCHEDULE[:2])
    assert sorted(store.holds) == [0, 1]
    assert rig.fake_table.encoder_angles(rig.fake_table.clock.now()) == pytest.approx([80, 60], abs=0.01)


def test_emulated_chips_follow_an_external_table_through_its_polled_angles():
    """The table belongs to someone else (another process, a real table): the simulated world follows it."""
    external = FakeTurntable(RealClock(), soft_limits=((-200, 200), (-200, 200)))
    with TurntableServer(external, transport="tcp", host="127.0.0.1", port=0) as server:
        config = fast_config(turntable="real")
        config.turntable.url = server.url
        with build_sim(config, seed=7) as rig:
            assert isinstance(rig.table, FollowedTable) and isinstance(rig.clock, RealClock)
            assert rig.fake_table is None
            rig.board.start()
            truth = rig.truth_fn()
            store = MemoryStore()
            record(rig, store, SCHEDULE)
    R = schedule_rotations(SCHEDULE, config.geometry)
    H, B = np.array(truth["sensors"]["accel"]["H"]), np.array(truth["sensors"]["accel"]["B"])
    for k, hold in store.holds.items():
        measured = H @ (np.nanmean(hold["samples"]["accel"], axis=0) - B)     # m/s^2, fixture frame
        expected = R[k].T @ np.array([0.0, 0.0, config.gravity_mps2])
        assert np.linalg.norm(measured - expected) < 0.05, (k, measured, expected)
    assert rig.table.track.late_reads == 0


def test_set_reset_strap_pulses_reach_the_hmc1053_through_the_gpio_line():
    with build_sim(fast_config("wearable")) as rig:
        rig.board.start()
        mag = rig.board.triads["mag"]
        mag.read_raw()
        model = rig.sim.emulators["mag"]
        expected = np.array(model.bridge_offset_v) * model.amp_gain * 4096 / 3.3
        assert mag.settings()["set_reset"] and np.allclose(mag.offset, expected, atol=1.5)


def test_real_rig_without_the_gpio_chip_says_which_line(tmp_path):
    config = fast_config("wearable")
    bench = SimulatedHardware(config, RealClock())
    gpiod = FakeGpiod()                                            # a machine with no /dev/gpiochip0
    with pytest.raises(HardwareUnavailable, match=r"set/reset GPIO /dev/gpiochip0 line 17: no such GPIO chip"):
        build_real(config, open_i2c=lambda n: bench.i2c, open_spi=lambda b, cs, m, hz: bench.spi(cs, m, hz),
                   open_gpio=lambda chip, line: open_set_reset_line(chip, line, gpiod=gpiod))


def test_real_mode_without_the_i2c_device_is_one_message_and_a_failing_exit(tmp_path):
    cfg = tmp_path / "real.toml"
    cfg.write_text((Path(__file__).resolve().parents[2] / "rig" / "configs" / "sim.toml").read_text()
                   + "\n[chips]\ni2c_bus = 97\n")
    done = subprocess.run([sys.executable, "-m", "rig.cli", "calibrate", "--config", str(cfg), "--out",
                           str(tmp_path / "out"), "--no-progress"], capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert "/dev/i2c-97" in done.stderr and "no such device" in done.stderr
    assert "Traceback" not in done.stderr + done.stdout


def test_simulated_chips_calibrate_against_a_sim_turntable_in_another_process(tmp_path):
    """`rig calibrate --sim` with [sim] turntable = "real": the chips are emulated, the table is another process.
    The session runs on the wall's clock, so a loaded machine skips ticks through the moves and the gyro integrates
    less well; its limits are widened to what such a session gives, since the test asks about the two processes, not
    the gyro's accuracy (the accelerometer's, from the holds, is still checked against the truth)."""
    port_file = tmp_path / "table.log"
    with open(port_file, "w") as log:
        table = subprocess.Popen([sys.executable, "-m", "rig.cli", "sim-turntable", "--port", "0"],
                                 stdout=log, stderr=subprocess.STDOUT, text=True)
    try:
        url = None
        for _ in range(100):
            text = port_file.read_text()
            if "serving" in text:
                url = text.split("serving ")[1].split()[0]
                break
            time.sleep(0.1)
        assert url, port_file.read_text()
        cfg = tmp_path / "mixed.toml"
        cfg.write_text((Path(__file__).resolve().parents[2] / "rig" / "configs" / "sim.toml").read_text()
                       .replace('url = "tcp://127.0.0.1:0"', f'url = "{url}"')
                       .replace("orientations = 20", "orientations = 9").replace("hold_s = 5.0", "hold_s = 0.4")
                       .replace("[limits.gyro]\nresidual_rms_max = 0.02\nB_std_max = 0.5\nH_std_pct_max = 0.2",
                                "[limits.gyro]\nresidual_rms_max = 0.2\nB_std_max = 5.0\nH_std_pct_max = 5.0")
                       + '\n[sim]\nturntable = "real"\n')
        done = subprocess.run([sys.executable, "-m", "rig.cli", "calibrate", "--sim", "--config", str(cfg),
                               "--out", str(tmp_path / "out"), "--no-progress"], capture_output=True, text=True,
                              timeout=120)
        assert done.returncode == 0, done.stdout + done.stderr
        errors = [line for line in done.stdout.splitlines() if "against the simulator's truth" in line]
        accel = float(errors[0].split("H error ")[1].split(" %")[0])
        assert len(errors) == 3 and accel < 0.5, done.stdout
    finally:
        table.terminate()
        table.wait(10)
