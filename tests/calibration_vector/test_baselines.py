"""The paper's comparisons: a general optimiser reaches the same optimum more slowly; the ellipsoid alone
cannot recover the mounting rotation."""

import numpy as np
from scipy.spatial.transform import Rotation

from rig.calibration.turntable.twostep import calibrate_two_step
from rig.calibration.turntable.vector_baselines import calibrate_sensor_frame_only, calibrate_sqp

from vector_synth import accel_truth, h_error, mag_truth, random_rotations


def test_sqp_reaches_the_same_optimum_as_the_joint_model(rng):
    truth = mag_truth(rng)
    R = random_rotations(20, rng)
    cal = calibrate_sqp(truth.holds(R, 0.0, rng), R, truth.norm)
    assert cal.converged and cal.method == "sqp"
    assert h_error(cal.H, truth.H) < 1e-5
    assert np.linalg.norm(cal.B - truth.B) < 1e-4 * np.linalg.norm(truth.B)
    assert np.linalg.det(cal.H) > 0


def test_two_step_needs_fewer_iterations_than_sqp(rng):
    truth = accel_truth(rng)
    R = random_rotations(20, rng)
    y = truth.holds(R, 0.3, rng)
    ours = calibrate_two_step(y, R, truth.norm, record_history=True)
    sqp = calibrate_sqp(y, R, truth.norm, record_history=True)
    target = 2 * h_error(ours.H, truth.H)
    ours_it = next(i for i, H in enumerate(ours.extra["history"], 1) if h_error(H, truth.H) < target)
    sqp_it = next(i for i, (_, H) in enumerate(sqp.extra["history"], 1) if h_error(H, truth.H) < target)
    assert ours_it < sqp_it


def test_sensor_frame_only_fits_magnitudes_but_misses_the_mounting_rotation(rng):
    truth = accel_truth(rng)
    mounting = Rotation.from_rotvec(np.radians([4.0, -3.0, 5.0])).as_matrix()
    truth.H = mounting @ truth.H                     # board rotated on the fixture
    R = random_rotations(20, rng)
    y = truth.holds(R, 0.0, rng)
    sf = calibrate_sensor_frame_only(y, truth.norm)
    np.testing.assert_allclose(sf.H, sf.H.T, atol=1e-12)
    assert sf.residual_rms < 1e-8 * truth.norm                     # |u| = G everywhere
    np.testing.assert_allclose(sf.H.T @ sf.H, truth.H.T @ truth.H, rtol=1e-7, atol=1e-12)
    Q = truth.H @ np.linalg.inv(sf.H)                              # what it leaves uncalibrated: a rotation
    np.testing.assert_allclose(Q @ Q.T, np.eye(3), atol=1e-7)
    angle = np.degrees(np.linalg.norm(Rotation.from_matrix(Q).as_rotvec()))
    assert angle > 5.0
    assert h_error(calibrate_two_step(y, R, truth.norm).H, truth.H) < 1e-8
    assert any("mounting" in w for w in sf.warnings)
