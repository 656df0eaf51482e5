"""`rig noise DIR`: a static log's Allan deviation and noise terms, from the command line as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from rig.io.recording import recording_session
from rig.io.session_writer import write_session

RIG = [sys.executable, "-m", "rig.cli"]
RATE_HZ = 100.0


def test_a_static_log_gives_back_the_white_noise_and_the_rate_random_walk_it_was_made_with(tmp_path):
    """20 minutes of a still unit: a gyro of white noise N = 0.2 counts/sqrt(Hz) (2 counts a sample, rounded) on a
    bias that walks at K = 0.01 counts sqrt(Hz), an accelerometer of white noise alone (0.003 m/s^2 a sample);
    the terms come back at their sizes, and no walk is claimed for the accelerometer beyond its own uncertainty
    (weighted by allantools' own error, which counts overlapping pairs as independent, the fit found walks in
    white noise and missed real ones)."""
    rng = np.random.default_rng(3)
    n = int(20 * 60 * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    walk = np.cumsum(rng.normal(0.0, 0.01 / np.sqrt(RATE_HZ), (n, 3)), axis=0)
    gyro = np.round(np.array([5.0, -3.0, 1.0]) + walk + rng.normal(0.0, 2.0, (n, 3)))
    accel = np.array([0.02, -0.01, 9.81]) + rng.normal(0.0, 0.003, (n, 3))
    session = recording_session(t, {"accel": accel, "gyro": gyro}, units={"accel": "m/s^2", "gyro": "counts"},
                                source="<static log>", sample_rate_hz=RATE_HZ)
    folder = write_session(session, tmp_path / "log")
    done = subprocess.run([*RIG, "noise", str(folder), "--json", str(tmp_path / "n.json")], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "gyro.x: white noise" in done.stdout and "Traceback" not in done.stderr
    report = json.loads((tmp_path / "n.json").read_text())
    # 20 minutes show a walk's slope on a few long taus only, where one axis's walk may look like a flicker floor:
    # the walk is judged on the median of the three axes
    walks = [report["sensors"]["gyro"][axis]["K"] for axis in "xyz"]
    assert abs(np.median(walks) - 0.01) < 0.3 * 0.01, walks
    for axis in "xyz":
        gyro_fit, accel_fit = report["sensors"]["gyro"][axis], report["sensors"]["accel"][axis]
        assert abs(gyro_fit["N"] - 0.202) < 0.01, gyro_fit["N"]          # rounding adds 1/12 count^2
        assert abs(accel_fit["N"] - 0.0003) < 0.000015, accel_fit["N"]
        assert accel_fit["K"] <= 3 * accel_fit["K_std"], (accel_fit["K"], accel_fit["K_std"])
        assert gyro_fit["tau_s"][0] == 1 / RATE_HZ and gyro_fit["tau_s"][-1] <= n / RATE_HZ / 3


def test_a_folder_that_is_not_a_session_is_named_in_one_line(tmp_path):
    (tmp_path / "meta.json").write_text("{}")
    done = subprocess.run([*RIG, "noise", str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr


def test_a_recording_that_moves_is_refused_not_given_an_allan_deviation(tmp_path):
    """Six faces and three turns: the Allan deviation of the motion would be read as noise terms."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from ferraris_synth import generate

    session, _ = generate(8)
    folder = write_session(session, tmp_path / "moving")
    done = subprocess.run([*RIG, "noise", str(folder)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "is not still" in done.stderr and "Traceback" not in done.stderr
