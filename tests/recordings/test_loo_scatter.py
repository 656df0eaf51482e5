"""The scatter of leave-one-out refits set beside the deviations a fit states, for the gyro and the
norm-only accelerometer taken as one Gauss-Newton step from the full fit: the step must be the refit (exact for a
linear model, within a few per cent for the gyro's), and the ratio must say 1 where the stated noise is the data's
and more where the data scatter more than the fit admits."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ferraris_synth import generate  # noqa: E402
from test_unseen_recordings import G, recording  # noqa: E402

from rig.calibration.numerics.jackknife import jackknife_sd, one_step_deletions, scatter_to_stated  # noqa: E402
from rig.calibration.recordings.recording import calibrate_recording  # noqa: E402
from rig.calibration.recordings.recording_fits import gyro_rotation_fit  # noqa: E402
from rig.calibration.recordings.recording_gyro import motion, summed_rate  # noqa: E402
from rig.calibration.recordings.recording_vector import gravity_directions  # noqa: E402
from rig.io.recording import recording_session  # noqa: E402
from rig.noise.statistics import loo_scatter_ratios  # noqa: E402


def test_one_step_deletion_is_the_refit_of_a_linear_model():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(30, 4)) * [1.0, 1e3, 1e-3, 5.0]          # columns of very different size
    y = X @ [1.0, 2e-3, 3e3, -1.0] + rng.normal(0, 0.1, 30)
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    groups = [np.array([i, i + 1]) for i in range(0, 30, 2)]
    refits = np.array([np.linalg.lstsq(np.delete(X, g, 0), np.delete(y, g), rcond=None)[0] - beta for g in groups])
    steps = one_step_deletions(X, y - X @ beta, groups)     # r = prediction - data, sign as least squares has it
    np.testing.assert_allclose(-steps, refits, rtol=1e-6, atol=1e-12)


def test_a_group_whose_absence_leaves_a_parameter_free_gives_no_scatter():
    X = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    assert one_step_deletions(X, np.zeros(3), [np.array([0]), np.array([2])]) is None


def test_the_ratio_is_one_where_the_stated_noise_is_the_datas_and_grows_with_noise_it_does_not_admit():
    rng = np.random.default_rng(1)
    X = rng.normal(size=(40, 3))
    ratios = {1.0: [], 3.0: []}
    for _ in range(200):
        for extra in ratios:
            noise = rng.normal(0, 1.0, 40) * np.where(np.arange(40) < 10, extra, 1.0)   # a quarter noisier
            y = X @ [1.0, 2.0, 3.0] + noise
            beta = np.linalg.lstsq(X, y, rcond=None)[0]
            stated = np.sqrt(np.diag(np.linalg.inv(X.T @ X)))                            # sigma 1, as a fit states it
            ratios[extra].append(scatter_to_stated(one_step_deletions(X, X @ beta - y, [np.array([i]) for i in
                                                                                        range(40)]), stated))
    assert 0.85 < np.median(ratios[1.0]) < 1.15, np.median(ratios[1.0])
    assert np.median(ratios[3.0]) > 1.5, np.median(ratios[3.0])


def test_the_gyros_one_step_scatter_is_its_refits():
    """Each turn and each motion left out and the gyro refitted, against the one-step deletions its fit reports."""
    session, _ = generate(4, shake_deg=5.0)
    rec = calibrate_recording(session)
    B, poses = rec.sensors["gyro"].B, rec.poses
    turns = [(summed_rate(session, t.rows, B), t.axis, t.angle_rad, t.angle_sd_rad, t.axis_sd_rad) for t in rec.turns]
    g = gravity_directions(session, rec.sensors["accel"], poses)
    carries = [(motion(session, poses[i], poses[j]), g[i], g[j]) for i, j in rec.carries]
    H, cov, info = gyro_rotation_fit(B, turns, carries)
    refits = [gyro_rotation_fit(B, [t for i, t in enumerate(turns) if i != k],
                                [c for i, c in enumerate(carries) if i != k - len(turns)], H0=H)[0] - H
              for k in range(len(turns) + len(carries))]
    stated = np.sqrt(np.diag(cov))
    refitted = float(np.median(jackknife_sd(np.array([d.ravel() for d in refits])) / stated))
    assert abs(info["loo_scatter_to_predicted"] / refitted - 1) < 0.05, (info["loo_scatter_to_predicted"], refitted)


def test_every_recording_fit_reports_its_scatter_to_the_twin():
    """Faces (refitted pose by pose) and the gyro of turns and motions; a hand session whose segments say no axis
    (the norm-only accelerometer) and its gyro of motions alone: each gives the twin a statistic."""
    session, _ = generate(5)
    faces = loo_scatter_ratios(session, calibrate_recording(session))
    rec = recording(2)
    segments = []
    for k in range(1, rec["pose"].max() + 1):
        t = rec["t"][rec["pose"] == k]
        segments.append({"name": f"pose {k}", "t0": float(t[0] + 0.1), "t1": float(t[-1] - 0.1), "kind": "static"})
    hand = recording_session(rec["t"], {"accel": rec["accel"], "gyro": rec["gyro"]},
                             units={"accel": "m/s^2", "gyro": "rad/s"}, source="hand", gravity=G, segments=segments)
    calibrated = calibrate_recording(hand)
    assert calibrated.sensors["accel"].method.startswith("recording-norm")
    norm_only = loo_scatter_ratios(hand, calibrated)
    for ratios in (faces, norm_only):
        assert set(ratios) == {"accel", "gyro"} and all(0.1 < v < 10 for v in ratios.values()), ratios
