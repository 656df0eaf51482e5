"""rig.unscented against filterpy's MerweScaledSigmaPoints and UnscentedKalmanFilter.update, its reference."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from rig import unscented


def _covariance(rng: np.random.Generator, n: int) -> np.ndarray:
    A = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-3, 1, n)
    return A @ A.T + 1e-9 * np.eye(n)


@pytest.mark.parametrize("n,m,alpha,beta,kappa", [(9, 3, 0.1, 2.0, 0.0), (4, 2, 1e-3, 2.0, 0.0),
                                                  (6, 4, 0.5, 0.0, 1.0), (1, 1, 1.0, 2.0, 2.0)])
def test_weights_points_and_update_equal_filterpys(n, m, alpha, beta, kappa):
    rng = np.random.default_rng(n * 100 + m)
    points = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
    weights = unscented.merwe_weights(n, alpha, beta, kappa)
    assert np.array_equal(weights.Wm, points.Wm) and np.array_equal(weights.Wc, points.Wc)
    A = rng.normal(size=(m, n))

    def hx(x):                                   # a nonlinear measurement
        return np.tanh(A @ x) + 0.1 * (A @ x) ** 2

    for _ in range(20):
        x, P = rng.normal(size=n), _covariance(rng, n)
        sig = unscented.sigma_points(x, P, weights)
        np.testing.assert_allclose(sig, points.sigma_points(x, P), rtol=1e-12, atol=1e-12 * np.sqrt(np.abs(P).max()))
        z, R = rng.normal(size=m), _covariance(rng, m)
        ukf = UnscentedKalmanFilter(dim_x=n, dim_z=m, dt=1.0, fx=lambda x, dt: x, hx=hx, points=points)
        ukf.x, ukf.P = x.copy(), P.copy()
        ukf.sigmas_f = sig.copy()
        ukf.update(z, R=R)
        x_new, P_new = unscented.update(x, P, sig, np.array([hx(s) for s in sig]), z, R, weights)
        scale = np.sqrt(np.abs(np.diag(P)))
        np.testing.assert_allclose(x_new, ukf.x, rtol=1e-10, atol=1e-10 * scale.max())
        np.testing.assert_allclose(P_new, ukf.P, rtol=1e-8, atol=1e-10 * np.abs(P).max())


def test_attitude_filter_weights_are_filterpys():
    from rig.attitude.ukf import STATE_DIM, UKFSettings, sigma_weights

    settings = UKFSettings()
    points = MerweScaledSigmaPoints(STATE_DIM, alpha=settings.alpha, beta=settings.beta, kappa=settings.kappa)
    c, wm0, wc0, wi = sigma_weights(settings)
    lam = settings.alpha ** 2 * (STATE_DIM + settings.kappa) - STATE_DIM
    assert (c, wm0, wc0, wi) == (np.sqrt(STATE_DIM + lam), points.Wm[0], points.Wc[0], points.Wm[1])
