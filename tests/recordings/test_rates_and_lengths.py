"""Recordings and turntable sessions at the rates and lengths users log at, unlike the two real files: each test is a
case that was wrong (a wrong H with exit 0, a replay that grew with the recording) and must now be refused in one
line naming the file, or come out right."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
from test_foreign_sessions import calibrate, write_foreign_session  # noqa: E402
from test_unseen_recordings import gyro_not_calibrated, imported, one_clear_line, recording, rig, write_csv  # noqa: E402


def test_a_turntable_session_logged_too_slowly_to_integrate_its_moves_is_refused(tmp_path):
    """At 1.5 Hz the table turns some 40 deg between gyro samples: the fit explained what the integration made up
    with an H thousands of times too large and exited 0 with a misfit warning. It must be refused naming the file
    and the rotation between samples (exit 3, a fault of the data)."""
    write_foreign_session(tmp_path / "s", rate=1.5, hold_s=20.0)
    res, cal = calibrate(tmp_path / "s", tmp_path / "out")
    assert res.returncode == 3 and cal is None, (res.returncode, res.stdout[-800:])
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1 and str(tmp_path / "s") in err, err
    assert "deg between two gyro samples" in err and "can be integrated" in err, err


def test_a_slow_logger_whose_moves_can_still_be_integrated_is_calibrated_within_its_uncertainty(tmp_path):
    """5 Hz, 15 deg between samples on the fastest move: the integration is good to the noise, so the refusal above
    must not reach it, and the gyro's H must sit within a few of its own stated standard deviations."""
    truth = write_foreign_session(tmp_path / "s", rate=5.0, hold_s=20.0)
    res, cal = calibrate(tmp_path / "s", tmp_path / "out")
    assert res.returncode == 0, res.stderr
    gyro = cal["sensors"]["gyro"]
    z = np.abs(np.array(gyro["H"]) - truth["gyro"][0]) / np.array(gyro["H_std"])
    assert z.max() < 4.0, z


def test_a_hand_recording_logged_too_slowly_is_refused_by_calibrate_and_discrepancy(tmp_path):
    """imu_tk's method on a 1.5 Hz log (poses held long enough for its 100 samples): each hand motion is two or three
    samples, and the gyro came out 4.4 times too large with exit 0. `rig calibrate` must refuse the gyro on a line
    naming the recording and how loosely its motions tell H (its accelerometer written, exit 1), and so must the
    twin, which replays the motions at the gyro's rate: its accelerometer's poses alone are analysed (exit 1, the
    gyro not analysed, with the reason)."""
    rec = recording(7, rate=1.5, poses=14, rest_s=100.0, pose_s=(80.0, 90.0))
    folder = imported(tmp_path, write_csv(tmp_path / "slow.csv", rec))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal"), "--no-progress")
    why = gyro_not_calibrated(done, tmp_path / "cal")
    assert str(folder) in why and "deg between two gyro samples" in why, why
    assert "tells H only to" in why and "%" in why, why             # how far, in numbers: what the fit can tell
    done = rig("discrepancy", str(folder), "--json", str(tmp_path / "d.json"), "--replicas", "10")
    line = one_clear_line(done)
    assert done.returncode == 1 and line.startswith("NOT analysed: gyro:") and "deg between two gyro samples" in line, \
        (done.returncode, done.stderr)
    assert json.loads((tmp_path / "d.json").read_text())["not_analysed"] == ["gyro"]


def test_a_hand_recording_at_5_hz_keeps_its_gyro(tmp_path):
    """The same hand at 5 Hz integrates well enough: calibrated, its gyro's scale right within 1 %."""
    rec = recording(7, rate=5.0, poses=14, rest_s=100.0, pose_s=(25.0, 30.0))
    folder = imported(tmp_path, write_csv(tmp_path / "five.csv", rec))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal"), "--no-progress")
    assert done.returncode == 0, done.stderr
    H = np.array(json.loads((tmp_path / "cal" / "calibration.json").read_text())["sensors"]["gyro"]["H"])
    assert np.allclose(np.linalg.svd(H @ np.linalg.inv(rec["Hg"]), compute_uv=False), 1.0, atol=0.01)
