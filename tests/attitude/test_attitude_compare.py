"""Frame alignment, error rotation and latency estimation of the validation."""

import math

import numpy as np
import pytest
from attitude_synth import make_motion
from scipy.spatial.transform import Rotation, Slerp

from rig.attitude.compare import AXES, axis_stats, compare, error_rpy_deg, rpy_deg
from rig.attitude.timing import carried_forward, delayed, estimate_gyro_delay, estimate_vector_delay
from rig.attitude.ukf import estimate_attitude
from rig.rotations import quat_from_matrix, rot_x, rot_y, rot_z


@pytest.fixture(scope="module")
def motion():
    return make_motion(seed=3)


def test_error_is_the_error_rotation_not_a_difference_of_euler_angles():
    R_ref = rot_z(0.3) @ rot_y(math.radians(89.95)) @ rot_x(0.2)
    R_est = R_ref @ rot_z(math.radians(0.1))          # 0.1 deg about the fixture z axis
    err = error_rpy_deg(R_ref[None], R_est[None])[0]
    assert err == pytest.approx([0.0, 0.0, 0.1], abs=1e-9)
    # near pitch 90 the Euler angles of the two differ by far more than the 0.1 deg between them
    assert np.abs(rpy_deg(R_est) - rpy_deg(R_ref)).max() > 5.0


def test_alignment_recovers_a_constant_rotation_between_world_and_navigation(motion):
    C = rot_z(math.radians(-12.0)) @ rot_x(math.radians(0.7))   # world -> navigation
    q_ref = quat_from_matrix(C.T @ motion.R)                      # the reference lives in the world frame
    est = estimate_attitude(motion.t, motion.gyro, motion.accel, motion.mag, field_uT=50.0)
    still = np.flatnonzero(motion.t < 2.0)
    comp = compare("ukf", est.q, q_ref, still[100:], np.flatnonzero(motion.t >= 2.0))
    C_est = np.array(comp.alignment["matrix"])
    angle = np.degrees(np.linalg.norm(Rotation.from_matrix(C_est.T @ C).as_rotvec()))
    assert angle < 0.1
    assert comp.alignment["angle_deg"] == pytest.approx(np.degrees(np.linalg.norm(Rotation.from_matrix(C).as_rotvec())),
                                                        abs=0.1)
    assert all(comp.stats[a].rms < 0.08 for a in AXES)
    assert all(comp.stats[a].corr > 0.999 for a in AXES)


def test_axis_stats_on_known_errors():
    err = np.column_stack([np.full(100, 0.5), np.r_[np.full(50, 1.0), np.full(50, -1.0)], np.zeros(100)])
    ref = np.column_stack([np.linspace(-10, 10, 100)] * 3)
    s = axis_stats(err, ref + err, ref)
    assert (s["roll"].rms, s["roll"].mean, s["roll"].sd) == pytest.approx((0.5, 0.5, 0.0))
    assert (s["pitch"].rms, s["pitch"].mean) == pytest.approx((1.0, 0.0))
    assert s["yaw"].corr == pytest.approx(1.0)
    assert s["pitch"].corr < s["roll"].corr


def test_gyro_latency_is_estimated_and_removed(motion):
    from attitude_synth import body_rate

    late = body_rate(motion.t - 0.004)                   # each row holds the rate of 4 ms earlier
    q_ref = quat_from_matrix(motion.R)
    rows = np.arange(150, len(motion.t))
    d = estimate_gyro_delay(motion.t, late, q_ref, rows)
    assert d == pytest.approx(0.004, abs=2e-4)
    assert np.abs(delayed(motion.t, late, d) - motion.omega)[rows[:-2]].max() < 0.01


def test_magnetometer_latency_is_estimated_and_carried_forward(motion):
    slerp = Slerp(motion.t, Rotation.from_matrix(motion.R))
    stale_R = slerp(np.clip(motion.t - 0.016, 0, None)).as_matrix()
    stale = np.einsum("nji,j->ni", stale_R, motion.field_nav)
    stale[1::2] = np.nan
    q_ref = quat_from_matrix(motion.R)
    d = estimate_vector_delay(motion.t, stale, q_ref, np.arange(150), np.arange(150, len(motion.t)))
    assert d == pytest.approx(0.016, abs=5e-4)
    fixed = carried_forward(motion.t, stale, motion.omega, d)
    true = np.einsum("nji,j->ni", motion.R, motion.field_nav)
    have = np.isfinite(stale[:, 0])
    before = np.abs(stale - true)[have].max()
    after = np.abs(fixed - true)[have].max()
    assert after < 0.02 * before
    assert np.isnan(fixed[~have]).all()


def test_latency_estimates_are_zero_for_fresh_samples(motion):
    q_ref = quat_from_matrix(motion.R)
    rows = np.arange(150, len(motion.t))
    assert abs(estimate_gyro_delay(motion.t, motion.omega, q_ref, rows)) < 2e-4
    accel = np.einsum("nji,j->ni", motion.R, [0.0, 0.0, 9.80665])
    assert abs(estimate_vector_delay(motion.t, accel, q_ref, np.arange(150), rows)) < 2e-4
