"""A gyro that answers to specific force is calibrated with it (`rig.calibration.recordings.g_sensitivity`): `rig
calibrate` on a hand-held recording finds it blind in the poses' means, writes it as `g_sensitivity` under the gyro, and
fits H on the rate without it; a gyro without one gets none."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_unseen_recordings import G, imported, recording, rig, write_csv  # noqa: E402

from rig.calibration.recordings.recording import calibrate_recording  # noqa: E402
from rig.discrepancy.recording import recording_tests  # noqa: E402
from rig.io.calibration_json import CalibrationFileError, read_calibration, triads_from_calibration  # noqa: E402
from rig.io.session_csv import read_session  # noqa: E402

SIZE_DPS_PER_G = 0.1              # ITG-3200: 0.05-0.1 deg/s per g (effects-research.md section 4)
POSES = 24


def with_g_sensitivity(rec: dict, size_dps_per_g: float, seed: int) -> np.ndarray:
    """The recording's raw gyro plus a random G of that size (largest singular value) times the true specific
    force; returns G in rad/s per m/s^2."""
    rng = np.random.default_rng(seed)
    G_true = rng.normal(size=(3, 3))
    G_true *= np.radians(size_dps_per_g) / G / np.linalg.svd(G_true, compute_uv=False)[0]
    force = (rec["accel"] - rec["Ba"]) @ rec["Ha"].T
    rec["gyro"] = rec["gyro"] + np.linalg.solve(rec["Hg"], (force @ G_true.T).T).T
    return G_true


def calibrated(tmp_path: Path, rec: dict) -> tuple[dict, Path]:
    folder = imported(tmp_path, write_csv(tmp_path / "log.csv", rec))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal"), "--no-progress")
    assert done.returncode == 0, (done.stdout, done.stderr)
    return read_calibration(tmp_path / "cal" / "calibration.json"), folder


def scale_error(H: np.ndarray, H_true: np.ndarray) -> float:
    """The accelerometer's frame is the calibrated one (imu_tk's convention): compare scales, not axes."""
    return float(np.abs(np.linalg.svd(H @ np.linalg.inv(H_true), compute_uv=False) - 1).max())


def test_a_gyro_that_answers_to_gravity_is_calibrated_with_it(tmp_path):
    rec = recording(2, poses=POSES)
    G_true = with_g_sensitivity(rec, SIZE_DPS_PER_G, seed=102)
    doc, folder = calibrated(tmp_path, rec)
    gyro = doc["sensors"]["gyro"]
    assert "g_sensitivity" in gyro, gyro
    found = gyro["g_sensitivity"]
    assert found["deg_s_per_g"] == pytest.approx(SIZE_DPS_PER_G, rel=0.15)
    G_found = np.array(gyro["H"]) @ np.array(found["K"])              # rad/s per m/s^2, calibrated frames
    # each entry is known to about 1e-5 rad/s per m/s^2 from 24 poses of this noise: 15-30 % of the whole
    assert np.linalg.norm(G_found - G_true) < 0.35 * np.linalg.norm(G_true)

    linear = calibrate_recording(read_session(folder)).sensors["gyro"].H
    assert scale_error(np.array(gyro["H"]), rec["Hg"]) < 0.5 * scale_error(linear, rec["Hg"])


def test_a_gyro_without_it_gets_none(tmp_path):
    doc, _ = calibrated(tmp_path, recording(2, poses=POSES))
    assert "g_sensitivity" not in doc["sensors"]["gyro"]


def test_the_file_round_trip_applies_it_and_a_broken_one_is_named(tmp_path):
    rec = recording(3, poses=POSES)
    with_g_sensitivity(rec, SIZE_DPS_PER_G, seed=103)
    doc, folder = calibrated(tmp_path, rec)
    gyro = triads_from_calibration(doc)["gyro"]
    assert gyro.g_sensitivity is not None
    session = read_session(folder)
    force = triads_from_calibration(doc)["accel"].apply(session.raw["accel"])
    rest = rec["pose"] == 0                                          # the initial rest: the rate is zero
    with_it = gyro.apply(session.raw["gyro"][rest], force[rest]).mean(axis=0)
    without = gyro.apply(session.raw["gyro"][rest]).mean(axis=0)
    assert np.linalg.norm(with_it) < 0.5 * np.linalg.norm(without)

    path = tmp_path / "cal" / "calibration.json"
    broken = json.loads(path.read_text())
    broken["sensors"]["gyro"]["g_sensitivity"]["K"] = [[1, 2, 3]]
    path.write_text(json.dumps(broken))
    with pytest.raises(CalibrationFileError, match=r"sensors\.gyro\.g_sensitivity\.K"):
        read_calibration(path)


def test_a_turn_about_the_vertical_between_two_poses_does_not_hide_it(tmp_path):
    """imu_tk's detector watches the accelerometer, which a turn about the vertical leaves still: seed 5 has a 71 deg
    one between poses 3 and 4, which it took, with both poses, for one pose whose gyro mean was the turn's (p = 0.58
    for the g-sensitivity). The gyro now parts them (`rig.calibration.recordings.gyro_still`): every pose the generator
    held is found, each inside one of them, and the calibration and the discrepancy analysis find the g-sensitivity on
    all."""
    rec = recording(5, poses=POSES)
    with_g_sensitivity(rec, SIZE_DPS_PER_G, seed=105)
    session = read_session(imported(tmp_path, write_csv(tmp_path / "log.csv", rec)))
    linear = calibrate_recording(session)
    held = [set(rec["pose"][p.rows]) - {-1} for p in linear.poses]       # -1: a motion's still-smooth ends
    assert held == [{k} for k in range(POSES)], held

    found = calibrate_recording(session, g_sensitivity=True).sensors["gyro"].g_sensitivity
    assert found is not None and found.poses == POSES
    assert found.deg_s_per_g == pytest.approx(SIZE_DPS_PER_G, rel=0.15)
    named = {t["effect"]: t for t in recording_tests(session, linear)}["gyro_g_sensitivity"]
    assert named["significant"] and named["magnitude"] == pytest.approx(SIZE_DPS_PER_G, rel=0.15)
