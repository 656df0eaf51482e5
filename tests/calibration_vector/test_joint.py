"""The joint estimator uses the rotations for B as well: more accurate than two-step with few holds."""

import numpy as np
import pytest

from rig.calibration.turntable.joint import calibrate_joint
from rig.calibration.turntable.twostep import calibrate_two_step
from rig.errors import CalibrationError

from vector_synth import accel_truth, h_error, mag_truth, random_rotations

TRIALS = 50
HOLD_NOISE = 1.0   # counts on a hold mean (e.g. 16 counts sample noise, 256 samples)


def _trial_errors(make_truth, rng):
    errs = []
    for _ in range(TRIALS):
        truth = make_truth(rng)
        R = random_rotations(12, rng)
        y = truth.holds(R, HOLD_NOISE, rng)
        two = calibrate_two_step(y, R, truth.norm)
        joint = calibrate_joint(y, R, truth.norm, y_std=np.full((12, 3), HOLD_NOISE))
        errs.append([np.linalg.norm(two.B - truth.B), np.linalg.norm(joint.B - truth.B),
                     h_error(two.H, truth.H), h_error(joint.H, truth.H)])
    return np.median(np.array(errs), axis=0)


@pytest.mark.parametrize("make_truth", [accel_truth, mag_truth], ids=["accel", "mag"])
def test_joint_more_accurate_than_two_step_with_12_holds(make_truth, rng):
    b_two, b_joint, h_two, h_joint = _trial_errors(make_truth, rng)
    assert b_two / b_joint >= 2.0
    assert h_two / h_joint >= 1.15


def test_joint_ml_covariance_matches_scatter(rng):
    truth = accel_truth(rng)
    R = random_rotations(12, rng)
    Bs, stds = [], []
    for _ in range(200):
        cal = calibrate_joint(truth.holds(R, HOLD_NOISE, rng), R, truth.norm, y_std=np.full((12, 3), 16.0),
                              counts=np.full(12, 256))
        Bs.append(cal.B)
        stds.append(cal.B_std)
    ratio = np.std(Bs, axis=0) / np.mean(stds, axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.25))
    assert cal.H_cov.shape == (9, 9) and cal.B_cov.shape == (3, 3)
    np.testing.assert_allclose(np.sqrt(np.diag(cal.H_cov)).reshape(3, 3), cal.H_std)


def test_joint_weights_down_a_noisy_hold(rng):
    truth = accel_truth(rng)
    R = random_rotations(15, rng)
    y = truth.holds(R, 0.2, rng)
    y[3] += [40.0, -30.0, 25.0]          # one hold disturbed, and its sample std says so
    std = np.full((15, 3), 0.2)
    std[3] = 50.0
    weighted = calibrate_joint(y, R, truth.norm, y_std=std)
    unweighted = calibrate_joint(y, R, truth.norm)
    assert np.linalg.norm(weighted.B - truth.B) < 0.2 * np.linalg.norm(unweighted.B - truth.B)


def test_joint_without_ml_and_with_level_reference(rng):
    truth = accel_truth(rng)
    R = random_rotations(8, rng)           # fewer than the ellipsoid needs: fine with a reference start
    cal = calibrate_joint(truth.holds(R, 0.0, rng), R, truth.norm, reference_world=(0, 0, 1), refine_ml=False)
    assert cal.method == "joint"
    assert h_error(cal.H, truth.H) < 1e-9
    without_start = calibrate_joint(truth.holds(R, 0.0, rng), R, truth.norm, refine_ml=False)
    assert h_error(without_start.H, truth.H) < 1e-9


def test_joint_without_reference_or_ellipsoid_finds_the_magnetometer(rng):
    for _ in range(20):
        truth = mag_truth(rng)
        R = random_rotations(8, rng)
        cal = calibrate_joint(truth.holds(R, 0.05, rng), R, truth.norm)
        assert h_error(cal.H, truth.H) < 2e-3
        assert np.linalg.det(cal.H) > 0


def test_joint_magnetometer_sign_and_direction(rng):
    truth = mag_truth(rng)
    R = random_rotations(12, rng)
    cal = calibrate_joint(truth.holds(R, 0.1, rng), R, truth.norm, reference_world=(0, 0, 1))
    assert np.linalg.det(cal.H) > 0
    np.testing.assert_allclose(cal.extra["reference_world"], truth.v, atol=0.05)
    assert h_error(cal.H, truth.H) < 1e-3


def test_joint_calibrates_a_grid_schedule_the_two_step_ellipsoid_cannot(rng):
    from rig.rotations import TableGeometry
    truth = accel_truth(rng)
    R = TableGeometry().rotation(np.repeat([0.0, 90, 180, 270], 3), np.tile([0.0, 120, 240], 4))
    y = truth.holds(R, 0.5, rng)
    for noise in (0.5, 5.0, 20.0):
        with pytest.raises(CalibrationError, match="only 8 distinct"):
            calibrate_two_step(truth.holds(R, noise, rng), R, truth.norm)
    cal = calibrate_joint(y, R, truth.norm, reference_world=(0, 0, 1), y_std=np.full((12, 3), 0.5))
    assert h_error(cal.H, truth.H) < 5e-4
    assert np.linalg.norm(cal.B - truth.B) < 3 * np.linalg.norm(cal.B_std) + 1e-9


@pytest.mark.parametrize("seed", [50, 53])
def test_six_holds_without_two_step_start_reach_the_bound_not_a_wrong_minimum(seed):
    """Six random holds (too few for the ellipsoid): the three fixture-axis starts used before ended in a
    minimum with reduced chi-square 2e4-3e4 and H off by 200-1200 % on these two schedules."""
    from procedures.paper_table1 import B_A, H_A
    from rig.units import STANDARD_GRAVITY as G
    from rig.calibration.turntable.bounds import cramer_rao
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(seed)
    R = Rotation.random(6, random_state=rng).as_matrix()
    sigma = np.sqrt(0.1)
    y = np.einsum("kji,j->ki", R, [0, 0, G]) @ np.linalg.inv(H_A).T + B_A + sigma * rng.standard_normal((6, 3))
    cal = calibrate_joint(y, R, G, y_std=np.full((6, 3), sigma))
    bound = cramer_rao(R, H_A, B_A, np.array([0, 0, G]), sigma)
    assert cal.extra["reduced_chi2"] < 10
    assert h_error(cal.H, H_A) < 5 * bound.H_rel_rms
    assert np.linalg.norm(cal.B - B_A) < 5 * bound.B_rms
    assert not cal.warnings


def test_a_hold_that_moved_is_warned_about_not_silently_fitted(rng):
    truth = accel_truth(rng)
    R = random_rotations(12, rng)
    y = truth.holds(R, HOLD_NOISE, rng)
    y[4] += 40 * HOLD_NOISE * np.array([1.0, -1.0, 0.5])
    cal = calibrate_joint(y, R, truth.norm, y_std=np.full((12, 3), HOLD_NOISE))
    assert cal.extra["reduced_chi2"] > 100
    assert any("misfit the model" in w for w in cal.warnings)
