"""A simulated rig's own table and surroundings ([sim] keys of its TOML) reach the world `rig calibrate --sim`
measures, and a value no table can have is refused naming the file and the key before anything runs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from .conftest import no_traceback, rig

RUN = ("calibrate", "--sim", "--seed", "7", "--time-scale", "50", "--no-progress")


def calibrated(tmp_path, name: str, sim: str) -> dict:
    toml = tmp_path / f"{name}.toml"
    toml.write_text("[schedule]\norientations = 12\n\n[sim]\n" + sim)
    done = rig(*RUN, "--config", toml, "--out", tmp_path / name, timeout=300)
    no_traceback(done)
    assert done.returncode == 0, done.stderr
    return json.loads((tmp_path / name / "calibration.json").read_text())["sensors"]


def z(a: dict, b: dict, key: str) -> float:
    d = np.subtract(a[key], b[key])
    u = np.hypot(a[f"{key}_std"], b[f"{key}_std"])
    return float(np.max(np.abs(d) / u))


def test_a_field_on_the_table_moves_the_magnetometer_and_nothing_else(tmp_path):
    """The same unit and noise on a plain table and on one carrying 2 uT along the inner axis (a constant field
    in the unit's frame): the magnetometer's offset moves by many sigma, the inertial sensors' stay within their
    uncertainty."""
    plain = calibrated(tmp_path, "plain", "")
    field = calibrated(tmp_path, "field", "table_field_uT = [0.0, 0.0, 2.0]\n")
    assert z(plain["mag"], field["mag"], "B") > 10
    assert z(plain["accel"], field["accel"], "B") < 1 and z(plain["gyro"], field["gyro"], "B") < 1


def test_a_table_off_its_zero_turns_the_inertial_frames(tmp_path):
    plain = calibrated(tmp_path, "plain", "")
    turned = calibrated(tmp_path, "turned", "table_zero_deg = [0.0, 0.5]\n")
    assert z(plain["accel"], turned["accel"], "H") > 10 and z(plain["gyro"], turned["gyro"], "H") > 4


@pytest.mark.parametrize("line, needle", [
    ("table_zero_deg = [0.0, 9.0]", "[sim] table_zero_deg = [0.0, 9.0] must be two finite numbers, each within +-5"),
    ("table_field_uT = [1.0, 2.0]", "[sim] table_field_uT = [1.0, 2.0] must be three finite numbers"),
    ("fixture_play_deg = -1", "[sim] fixture_play_deg = -1 must be a finite number, 0 to 10"),
    ('table_tilt_deg = "a"', "[sim] table_tilt_deg = 'a' must be three finite numbers"),
])
def test_a_sim_value_no_table_can_have_is_refused(tmp_path, line, needle):
    toml = tmp_path / "rig.toml"
    toml.write_text(f"[sim]\n{line}\n")
    done = rig(*RUN, "--config", toml, "--out", tmp_path / "never")
    no_traceback(done)
    assert done.returncode == 2 and str(toml) in done.stderr and needle in done.stderr, done.stderr
    assert not (tmp_path / "never").exists()
