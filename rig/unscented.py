"""The scaled unscented transform (van der Merwe, 2004): weights, sigma points and one Kalman update, in numpy.

These are filterpy's `MerweScaledSigmaPoints` and `UnscentedKalmanFilter.update` with the same formulas in
the same order of operations, for states whose residuals are plain differences. filterpy stays the
reference (tests/startup/test_unscented.py and the gyro tests hold both equal to round-off), but importing
it pulls scipy.stats, ~0.4 s, more than a whole `rig calibrate --from` may take (issue 17, start-up).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MerweWeights:
    """Mean and covariance weights of the 2n+1 sigma points, and lambda = alpha^2 (n + kappa) - n."""

    n: int
    alpha: float
    beta: float
    kappa: float
    lam: float
    Wm: np.ndarray
    Wc: np.ndarray


def merwe_weights(n: int, alpha: float, beta: float, kappa: float) -> MerweWeights:
    lam = alpha ** 2 * (n + kappa) - n
    c = 0.5 / (n + lam)
    Wm, Wc = np.full(2 * n + 1, c), np.full(2 * n + 1, c)
    Wc[0] = lam / (n + lam) + (1 - alpha ** 2 + beta)
    Wm[0] = lam / (n + lam)
    return MerweWeights(n, alpha, beta, kappa, lam, Wm, Wc)


def sigma_points(x: np.ndarray, P: np.ndarray, weights: MerweWeights) -> np.ndarray:
    """(2n+1, n): x, then x + and x - the rows of the upper Cholesky factor of (n + lambda) P."""
    U = _upper_cholesky((weights.lam + weights.n) * P)
    return np.concatenate([x[None, :], x + U, x - U])


def update(x: np.ndarray, P: np.ndarray, sigmas: np.ndarray, z_sigmas: np.ndarray, z: np.ndarray, R: np.ndarray,
           weights: MerweWeights) -> tuple[np.ndarray, np.ndarray]:
    """The posterior (x, P) given the measurement z, the sigma points and their predicted measurements.

    The unscented transform of the measurement: zp = sum Wm_i Z_i, S = sum Wc_i (Z_i - zp)(Z_i - zp)^T + R;
    the cross covariance Pxz = sum Wc_i (X_i - x)(Z_i - zp)^T; K = Pxz S^-1; x + K (z - zp), P - K S K^T.
    """
    zp = weights.Wm @ z_sigmas
    dz = z_sigmas - zp[None, :]
    S = np.dot(dz.T, np.dot(np.diag(weights.Wc), dz)) + R
    Pxz = (weights.Wc[:, None] * (sigmas - x)).T @ (z_sigmas - zp)
    K = np.dot(Pxz, np.linalg.inv(S))
    return x + np.dot(K, z - zp), P - np.dot(K, np.dot(S, K.T))


def _upper_cholesky(A: np.ndarray) -> np.ndarray:
    """U with U^T U = A, by LAPACK's upper factorisation as scipy.linalg.cholesky (filterpy's default) runs it;
    the transposed lower factor is the same matrix up to round-off, which ill-conditioning amplifies."""
    try:
        return np.linalg.cholesky(A, upper=True)
    except TypeError:          # numpy < 2.0 has no upper=
        return np.linalg.cholesky(A).T
