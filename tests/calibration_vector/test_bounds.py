"""The Cramer-Rao bound of the vector calibration: matches the joint estimator's scatter, grows with fewer
holds, and refuses schedules that cannot determine B and H."""

import numpy as np
import pytest

from rig.calibration.turntable.bounds import cramer_rao
from rig.calibration.turntable.joint import calibrate_joint
from rig.errors import CalibrationError
from rig.rotations import rot_x, rot_z

from vector_synth import G, Truth, accel_truth, mag_truth, random_rotations

MC_TRIALS = 400
HOLD_NOISE = 1.0   # counts on a hold mean


def distorted_truth(rng: np.random.Generator) -> Truth:
    """Strongly anisotropic, non-symmetric sensor matrix and a tilted reference: a near-scalar H would hide
    a transposed Jacobian or inverse propagation."""
    K = np.array([[40.0, 12.0, -6.0], [-3.0, 25.0, 9.0], [5.0, -8.0, 60.0]])
    v = G * np.array([0.3, -0.2, 0.93]) / np.linalg.norm([0.3, -0.2, 0.93])
    return Truth(H=np.linalg.inv(K), B=rng.uniform(-300, 300, 3), v=v, norm=G)


def _monte_carlo(truth, R, E, rng):
    dB, dH, dK, tilt = [], [], [], []
    K = np.linalg.inv(truth.H)
    v_unit = truth.v / truth.norm
    for _ in range(MC_TRIALS):
        cal = calibrate_joint(truth.holds(R, HOLD_NOISE, rng), R, truth.norm, y_std=np.full((len(R), 3), HOLD_NOISE))
        dB.append(cal.B - truth.B)
        dH.append((cal.H - truth.H).ravel())
        dK.append((np.linalg.inv(cal.H) - K).ravel())
        tilt.append(E.T @ (np.asarray(cal.extra["reference_world"]) / truth.norm - v_unit))
    return np.array(dB), np.array(dH), np.array(dK), np.array(tilt)


@pytest.mark.parametrize("make_truth", [accel_truth, mag_truth, distorted_truth], ids=["accel", "mag", "distorted"])
def test_joint_scatter_matches_the_bound(make_truth, rng):
    truth = make_truth(rng)
    R = random_rotations(12, rng)
    crb = cramer_rao(R, truth.H, truth.B, truth.v, HOLD_NOISE)
    dB, dH, dK, tilt = _monte_carlo(truth, R, crb.v_tangent_basis, rng)
    assert np.mean(np.sum(dB**2, axis=1)) / crb.B_rms**2 == pytest.approx(1.0, abs=0.15)
    h_ms = np.mean(np.sum(dH**2, axis=1)) / np.linalg.norm(truth.H) ** 2
    assert h_ms / crb.H_rel_rms**2 == pytest.approx(1.0, abs=0.15)
    assert np.trace(np.cov(dK.T)) / np.trace(crb.covariance[3:12, 3:12]) == pytest.approx(1.0, abs=0.15)
    assert np.mean(np.sum(tilt**2, axis=1)) / np.trace(crb.covariance[12:14, 12:14]) == pytest.approx(1.0, abs=0.15)
    np.testing.assert_allclose(np.cov(dH.T), crb.H_cov, atol=0.25 * np.abs(crb.H_cov).max())
    # all 14 principal directions of the information: the whitened errors have unit variance in each
    w, V = np.linalg.eigh(crb.information)
    z = np.column_stack([dB, dK, tilt]) @ V * np.sqrt(w)
    assert np.all(np.abs(np.mean(z**2, axis=0) - 1.0) < 0.3)


def test_information_matches_finite_differences_of_the_model(rng):
    """F = J^T J / sigma^2 with J by central differences of y_k = K R_k^T v + B over (B, K, tilts of v)."""
    truth = distorted_truth(rng)
    R = random_rotations(10, rng)
    crb = cramer_rao(R, truth.H, truth.B, truth.v, 2.0)
    E = crb.v_tangent_basis

    def predict(p):
        w = truth.v / truth.norm + E @ p[12:14]
        return (np.einsum("kji,j->ki", R, truth.norm * w / np.linalg.norm(w)) @ p[3:12].reshape(3, 3).T + p[0:3]).ravel()

    p0 = np.concatenate([truth.B, np.linalg.inv(truth.H).ravel(), np.zeros(2)])
    step = 1e-6 * np.maximum(np.abs(p0), 1.0)
    J = np.column_stack([(predict(p0 + d) - predict(p0 - d)) / (2 * d[i]) for i, d in enumerate(np.diag(step))])
    np.testing.assert_allclose(crb.information, J.T @ J / 4.0, rtol=1e-6, atol=1e-8 * np.abs(J.T @ J).max())


def test_bound_grows_when_holds_are_removed(rng):
    truth = accel_truth(rng)
    R = random_rotations(20, rng)
    full = cramer_rao(R, truth.H, truth.B, truth.v, HOLD_NOISE)
    fewer = cramer_rao(R[:12], truth.H, truth.B, truth.v, HOLD_NOISE)
    assert np.linalg.eigvalsh(fewer.covariance - full.covariance).min() > -1e-9 * np.abs(full.covariance).max()
    assert fewer.B_rms > full.B_rms and fewer.H_rel_rms > full.H_rel_rms and fewer.vector_rel_rms > full.vector_rel_rms


def test_a_hold_with_huge_noise_counts_as_removed(rng):
    truth = mag_truth(rng)
    R = random_rotations(13, rng)
    sigma = np.full((13, 3), HOLD_NOISE)
    sigma[5] = 1e6
    down_weighted = cramer_rao(R, truth.H, truth.B, truth.v, sigma)
    removed = cramer_rao(np.delete(R, 5, axis=0), truth.H, truth.B, truth.v, HOLD_NOISE)
    np.testing.assert_allclose(down_weighted.covariance, removed.covariance, rtol=1e-6, atol=1e-12)


def test_bound_grows_as_the_schedule_approaches_coplanar(rng):
    truth = accel_truth(rng)
    inner = np.radians(np.arange(0, 360, 30))
    rms = []
    for tilt_deg in (60.0, 20.0, 5.0):
        outer = np.radians(np.tile([90.0 - tilt_deg, 90.0, 90.0 + tilt_deg], 4))
        R = np.array([rot_x(a) @ rot_z(b) for a, b in zip(outer, inner)])
        rms.append(cramer_rao(R, truth.H, truth.B, truth.v, HOLD_NOISE).H_rel_rms)
    assert rms[0] < rms[1] < rms[2] and rms[2] > 10 * rms[0]


@pytest.mark.parametrize("schedule", ["vertical_outer_axis", "inner_axis_only"])
def test_unobservable_schedule_is_refused(schedule, rng):
    truth = accel_truth(rng)
    a = np.radians(np.arange(0, 360, 30))
    b = np.radians(np.arange(0, 360, 45)[np.arange(12) % 8])
    if schedule == "vertical_outer_axis":      # gravity never reaches fixture x (conventions.md)
        R = np.array([rot_z(p) @ rot_x(q) for p, q in zip(a, b)])
    else:                                      # a cone about fixture z: offset confounded with scale
        R = np.array([rot_x(np.radians(30.0)) @ rot_z(p) for p in a])
    with pytest.raises(CalibrationError, match="bound is infinite"):
        cramer_rao(R, truth.H, truth.B, truth.v, HOLD_NOISE)


def test_bad_sigma_is_refused(rng):
    truth = accel_truth(rng)
    R = random_rotations(12, rng)
    with pytest.raises(CalibrationError, match="sigma"):
        cramer_rao(R, truth.H, truth.B, truth.v, np.ones(7))
    with pytest.raises(CalibrationError, match="sigma"):
        cramer_rao(R, truth.H, truth.B, truth.v, 0.0)
