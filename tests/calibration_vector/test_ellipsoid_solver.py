"""The fast paths of the two-step solve give the same answers as the plain formulation they replace."""

import numpy as np
import pytest

from rig.calibration.numerics.ellipsoid import fit_ellipsoid
from rig.calibration.turntable.twostep import calibrate_two_step
from rig.errors import CalibrationError


def _lstsq_centre(y: np.ndarray) -> np.ndarray:
    """Eqs. 15-17 by numpy's lstsq on the design matrix, no normal equations."""
    mean = y.mean(axis=0)
    p = (y - mean) / np.sqrt(((y - mean) ** 2).sum(axis=1).mean())
    qi, qj = [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]
    D = np.concatenate((p[:, qi] * p[:, qj] * [1, 1, 1, 2, 2, 2], 2 * p), axis=1)
    c = np.linalg.lstsq(D, np.ones(len(p)), rcond=None)[0]
    M = c[[0, 3, 4, 3, 1, 5, 4, 5, 2]].reshape(3, 3)
    return mean - np.sqrt(((y - mean) ** 2).sum(axis=1).mean()) * np.linalg.solve(M, c[6:])


@pytest.mark.parametrize("cap_deg", [60.0, 100.0, 180.0])
def test_normal_equations_match_lstsq_on_poorly_spread_anisotropic_points(cap_deg):
    rng = np.random.default_rng(int(cap_deg))
    polar = np.radians(rng.uniform(0, cap_deg, 14))
    azim = rng.uniform(0, 2 * np.pi, 14)
    d = np.column_stack([np.sin(polar) * np.cos(azim), np.sin(polar) * np.sin(azim), np.cos(polar)])
    K = np.diag([150.0, 900.0, 2500.0]) @ (np.eye(3) + 0.3 * rng.standard_normal((3, 3)))
    y = d @ K.T + [3.1e4, -4.7e4, 1.2e4] + 0.5 * rng.standard_normal((14, 3))
    centre = fit_ellipsoid(y, min_spread=0.0).center
    assert np.linalg.norm(centre - _lstsq_centre(y)) < 1e-7 * np.linalg.norm(K)


def test_fit_refuses_a_flat_cap_unless_told_it_only_starts_an_optimiser():
    rng = np.random.default_rng(3)
    polar = np.radians(rng.uniform(0, 8, 12))
    azim = rng.uniform(0, 2 * np.pi, 12)
    y = 400 * np.column_stack([np.sin(polar) * np.cos(azim), np.sin(polar) * np.sin(azim), np.cos(polar)])
    with pytest.raises(CalibrationError, match="coplanar"):
        fit_ellipsoid(y)
    assert np.all(np.isfinite(fit_ellipsoid(y, min_spread=0.0).center))


def test_rounds_taken_in_chunks_equal_the_papers_sequential_rounds(rng):
    from scipy.spatial.transform import Rotation
    R = Rotation.random(20, random_state=rng).as_matrix()
    K = 400 * (np.eye(3) + 0.05 * rng.standard_normal((3, 3)))
    y = np.einsum("kji,j->ki", R, [0, 0, 9.81]) @ K.T + [50.0, -20.0, 30.0] + 0.5 * rng.standard_normal((20, 3))
    cal = calibrate_two_step(y, R, 9.81, record_history=True, tol=1e-12)
    fit = fit_ellipsoid(y)
    Z = (y - fit.center).T
    Zpinv = np.linalg.pinv(Z)
    w, V = fit.axes
    H = 9.81 * (V * np.sqrt(w)) @ V.T
    for k in range(cal.iterations):                      # (i) u_1 from H, then (ii) H from u_1, one round at a time
        v = np.einsum("kab,bc,ck->a", R, H, Z) / len(y)
        v *= 9.81 / np.linalg.norm(v)
        H_next = np.einsum("kji,j->ki", R, v).T @ Zpinv
        converged = np.linalg.norm(H_next - H) < 1e-12 * np.linalg.norm(H_next)
        H = H_next
        assert converged == (k == cal.iterations - 1)
    assert converged
    H = H * 9.81 / np.mean(np.linalg.norm(Z.T @ H.T, axis=1))
    np.testing.assert_allclose(cal.H, H * np.sign(np.linalg.det(H)), rtol=1e-9, atol=1e-12)
