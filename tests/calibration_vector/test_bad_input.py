"""Bad input gets a clear CalibrationError, never a silently wrong matrix."""

import numpy as np
import pytest

from rig.calibration.numerics.ellipsoid import fit_ellipsoid
from rig.calibration.turntable.joint import calibrate_joint
from rig.calibration.turntable.twostep import calibrate_two_step
from rig.calibration.numerics.uncertainty import bootstrap_uncertainty
from rig.calibration.turntable.vector_baselines import calibrate_sensor_frame_only, calibrate_sqp
from rig.errors import CalibrationError
from rig.rotations import rot_x, rot_z

from vector_synth import accel_truth, random_rotations

SOLVERS = [calibrate_two_step, calibrate_sqp, calibrate_joint]


@pytest.fixture
def holds(rng):
    truth = accel_truth(rng)
    R = random_rotations(12, rng)
    return truth, truth.holds(R, 0.5, rng), R


@pytest.mark.parametrize("solver", SOLVERS)
def test_nan_row_is_named(solver, holds):
    truth, y, R = holds
    y[4, 1] = np.nan
    with pytest.raises(CalibrationError, match=r"hold\(s\) \[4\]"):
        solver(y, R, truth.norm)


@pytest.mark.parametrize("solver", SOLVERS)
def test_saturated_axis_is_named(solver, holds):
    truth, y, R = holds
    y[7, 2] = 32767.0
    with pytest.raises(CalibrationError, match="hold 7 axis z is saturated"):
        solver(y, R, truth.norm, full_scale=32768)


@pytest.mark.parametrize("solver", SOLVERS)
def test_too_few_orientations(solver, holds):
    truth, y, R = holds
    with pytest.raises(CalibrationError, match="orientations, need at least"):
        solver(y[:5], R[:5], truth.norm)


@pytest.mark.parametrize("solver", SOLVERS)
def test_coplanar_orientations(solver, rng):
    truth = accel_truth(rng)
    a = np.radians(np.linspace(0, 330, 12))
    R = rot_z(a) @ rot_x(np.radians(np.tile([20.0, 70, 130, 250], 3)))
    with pytest.raises(CalibrationError, match="coplanar"):
        solver(truth.holds(R, 0.5, rng), R, truth.norm)


def test_bad_rotations_and_shapes(holds):
    truth, y, R = holds
    R_bad = R.copy()
    R_bad[2] *= 1.1
    with pytest.raises(CalibrationError, match=r"rotation\(s\) \[2\] are not proper"):
        calibrate_two_step(y, R_bad, truth.norm)
    with pytest.raises(CalibrationError, match="12 raw means but 11 rotations"):
        calibrate_two_step(y, R[:11], truth.norm)
    with pytest.raises(CalibrationError, match=r"shape \(n, 3\)"):
        calibrate_sensor_frame_only(y[:, :2], truth.norm)


def test_ellipsoid_rejects_points_on_a_hyperboloid(rng):
    z = rng.uniform(-1.5, 1.5, 30)
    t = rng.uniform(0, 2 * np.pi, 30)
    r = np.sqrt(1 + z**2)
    pts = np.column_stack([r * np.cos(t), r * np.sin(t), z])   # x^2 + y^2 - z^2 = 1
    with pytest.raises(CalibrationError, match="not an ellipsoid"):
        fit_ellipsoid(pts)


def test_ellipsoid_recovers_center_and_shape(rng):
    A_root = np.eye(3) + 0.1 * rng.standard_normal((3, 3))
    d = rng.standard_normal((30, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    centre = np.array([100.0, -50.0, 20.0])
    pts = d @ np.linalg.inv(A_root).T + centre
    fit = fit_ellipsoid(pts)
    np.testing.assert_allclose(fit.center, centre, atol=1e-9)
    np.testing.assert_allclose(fit.shape, A_root.T @ A_root, atol=1e-9)
    assert fit.residual < 1e-12


def test_joint_rejects_bad_weights(holds):
    truth, y, R = holds
    std = np.full((12, 3), 2.0)
    std[5, 0] = np.nan
    with pytest.raises(CalibrationError, match=r"y_std must be finite and >= 0; holds \[5\]"):
        calibrate_joint(y, R, truth.norm, y_std=std)
    with pytest.raises(CalibrationError, match=r"counts must be >= 1, holds \[2\]"):
        calibrate_joint(y, R, truth.norm, y_std=np.full((12, 3), 2.0), counts=[10] * 2 + [0] + [10] * 9)


def test_joint_floors_zero_std_at_quantisation(holds):
    truth, y, R = holds
    quiet = calibrate_joint(y, R, truth.norm, y_std=np.zeros((12, 3)), counts=np.full(12, 12))
    floor = calibrate_joint(y, R, truth.norm, y_std=np.full((12, 3), 1 / np.sqrt(12)), counts=np.full(12, 12))
    np.testing.assert_allclose(quiet.B_std, floor.B_std)
    assert np.all(np.isfinite(quiet.B_std))


def test_bootstrap_gives_spread_and_refuses_thin_schedules(rng):
    truth = accel_truth(rng)
    R = random_rotations(20, rng)
    y = truth.holds(R, 0.5, rng)
    B_std, H_std = bootstrap_uncertainty(calibrate_two_step, y, R, truth.norm, n_boot=40, seed=1)
    assert B_std.shape == (3,) and H_std.shape == (3, 3)
    assert np.all(B_std > 0.01) and np.all(B_std < 5.0)
    with pytest.raises(CalibrationError, match="bootstrap"):
        bootstrap_uncertainty(calibrate_two_step, y[:9], R[:9], truth.norm, n_boot=20)
