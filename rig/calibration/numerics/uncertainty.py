"""Bootstrap standard deviations of B and H by resampling holds.

Works for any solver (two-step has no analytic covariance); the spread over resampled hold sets also
captures errors the noise model misses (table angle errors, a hold disturbed by vibration).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.errors import CalibrationError

MIN_SUCCESS_SHARE = 0.8


def bootstrap_uncertainty(fn: Callable[..., TriadCalibration], y_means: np.ndarray, R: np.ndarray, norm: float, *,
                          n_boot: int = 200, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(B_std (3,), H_std (3, 3)) over `n_boot` resamplings (with replacement) of the holds.

    Resamples that the solver refuses (too few distinct orientations drawn) are skipped; if more than 20 %
    are refused the schedule is too thin for a bootstrap and CalibrationError is raised.
    """
    y = np.asarray(y_means, dtype=float)
    R = np.asarray(R, dtype=float)
    rng = np.random.default_rng(seed)
    Bs, Hs = [], []
    for _ in range(n_boot):
        idx = rng.integers(0, len(y), len(y))
        try:
            cal = fn(y[idx], R[idx], norm)
        except CalibrationError:
            continue
        Bs.append(cal.B)
        Hs.append(cal.H)
    if len(Bs) < MIN_SUCCESS_SHARE * n_boot or len(Bs) < 2:
        raise CalibrationError(f"bootstrap: only {len(Bs)} of {n_boot} resamples could be calibrated; "
                               "too few or too similar orientations for a bootstrap")
    return np.std(Bs, axis=0, ddof=1), np.std(Hs, axis=0, ddof=1)


def inherited_frame_cov(reference: TriadCalibration, H: np.ndarray) -> np.ndarray | None:
    """The covariance of vec(H) (9, 9) that a calibration takes from the frame of the one it was tied to.

    A recording's gyro is fitted against the gravity directions of the calibrated accelerometer, taken as exact:
    where the accelerometer's frame is itself uncertain (the faces of a hand-held session fix it only to their
    tilt priors), the gyro turns with it, `dH = [dtheta]x H`. The accelerometer's small rotation is the
    antisymmetric part of `dH_a H_a^-1`, its covariance from the accelerometer's H_cov. Without the gyro's
    share, 12 synthetic Ferraris recordings had off-diagonal errors 2.5 times their stated deviation (RMS z).
    """
    if reference.H_cov is None:
        return None
    Ha_inv = np.linalg.inv(reference.H)
    pairs = ((2, 1), (0, 2), (1, 0))                        # theta_k = (A[i, j] - A[j, i]) / 2, A = dH_a H_a^-1
    L = np.zeros((3, 9))
    for k, (i, j) in enumerate(pairs):
        for r, c, sign in ((i, j, 0.5), (j, i, -0.5)):      # A[r, c] = sum_m dH_a[r, m] Ha_inv[m, c]
            L[k, 3 * r:3 * r + 3] += sign * Ha_inv[:, c]
    cov_theta = L @ reference.H_cov @ L.T
    J = np.stack([np.cross(np.eye(3)[k], H.T).T.ravel() for k in range(3)], axis=1)    # vec([e_k]x H)
    return J @ cov_theta @ J.T
