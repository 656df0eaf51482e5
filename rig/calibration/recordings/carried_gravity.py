"""The gyro's H from gravity carried across hand motions, and what its stated deviation takes in.

Each motion's calibrated rate is integrated from the last sample of one pose to the first of the next, and H is
chosen so that the rotation carries the gravity direction of the first pose onto the second: residual
`R(H)^T g0 - g1` on unit vectors (imu_tk's MultiPosGyroResidual; Tedaldi et al., ICRA 2014). A residual is a
difference of unit vectors, two equations per motion (its component along g is second order), so the residuals'
variance is their sum of squares over 2 n - 9 (Gauss-Newton covariance: Seber & Wild, Nonlinear Regression, 1989,
sec. 2.1). That covers what varies from motion to motion: rate noise, a hand's tilt at the poses, and the part of
the integration error that does. Three errors are common to the motions, and the residuals cannot show what H
absorbs of them; each is propagated through the fit's gain `dH = -(J^T J)^-1 J^T dr`:

* The rate between samples (the integration error of the sample rate). `integrate.interval_terms` reads it as the
  cubic through four samples; how far that is off is told by two other readings of the same samples, per motion
  k as a rotation vector in the body frame at the motion's end: D_k = rotvec(R_linear^T R_cubic), the linear rate
  between samples (`integrate.interval_rotvecs`, the trapezoid with its coning term), and Dd_k =
  rotvec(R_half^T R_cubic), the cubic through every second sample (step doubling). The cubic's error e_k follows
  them: on synthetic hand motions against their exact rotation, e = 1.0 D (RMS; correlation 0.8) where the hand
  sets the unit down abruptly, a corner in the rate falling anywhere between two samples (at 50, 100 and 200 Hz
  alike), and e = -Dd / 15 (correlation 1.0: Richardson's share for the cubic's fourth order) where the rate axis
  wobbles smoothly at 4-14 Hz, D there 25 times e. So e_k = beta D_k + gamma Dd_k, the shares common to the
  motions, with the priors N(0, INTEGRATION_PRIOR_SD^2): the coherent part of the commutation (coning) and
  quadrature errors, which H would absorb unseen. Linearised at the fit, the shares H cannot absorb are estimated
  from the residuals (Gauss-Newton with a Gaussian prior: Seber & Wild, sec. 2.8), H is corrected by them, and
  H's covariance takes in theirs, `dH/d(beta, gamma) cov dH/d(beta, gamma)^T`.
* The bias B (the mean of a rest or of the poses), whose error enters each motion by its duration.
* The gravity directions, from the calibrated accelerometer: its B and H are uncertain too, and turn the
  directions the gyro carries (its frame, and each pose within it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.turntable.gyro import MoveSet, decimated, integrated_quats
from rig.calibration.numerics.integrate import interval_rotvecs, product_of_exps, quat_exp
from rig.quaternions import matrix_from_quat, quat_conjugate, quat_multiply, rotvec_from_quat
from rig.session_data import MoveStream

INTEGRATION_PRIOR_SD = (1.0, 1.0 / 15.0)   # the cubic's error in units of the readings' disagreement D and of step
# doubling's Dd before the data say it: of D's size (1.0 at corners, 0.04 where the axis wobbles smoothly), and of a
# second-order scheme's Richardson share of Dd at most (1/3; 1/15 for the fourth order the cubic has on smooth rates)


@dataclass
class CarriedFit:
    H: np.ndarray
    H_cov: np.ndarray              # (9, 9): residuals, the rate between samples, the bias, the gravity directions
    residuals: np.ndarray          # (n, 3)
    iterations: int
    converged: bool
    rank: int
    reading_cov: np.ndarray        # (9, 9) the share of the rate between samples
    shares: np.ndarray             # the cubic's error found, in units of D and Dd (beta, gamma)
    shares_sd: np.ndarray
    disagreement_rad: np.ndarray   # |D_k| per motion


def reading_disagreement(moves: list[MoveStream], B: np.ndarray, H: np.ndarray) -> np.ndarray:
    """D_k (n, 3): rotvec(R_linear^T R_cubic) of each motion at the calibration (B, H), rad, in the body frame at
    the motion's end."""
    cubic = integrated_quats(H, MoveSet.build(moves, B))
    linear = np.array([product_of_exps(interval_rotvecs(m.t, (m.y - B) @ H.T)) for m in moves])
    return rotvec_from_quat(quat_multiply(quat_conjugate(linear), cubic))


def step_doubling(moves: list[MoveStream], B: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Dd_k (n, 3): rotvec(R_half^T R_cubic) of each motion, R_half integrated from every second sample (and the
    last), rad, in the body frame at the motion's end."""
    cubic = integrated_quats(H, MoveSet.build(moves, B))
    half = integrated_quats(H, MoveSet.build(decimated(moves, 2), B))
    return rotvec_from_quat(quat_multiply(quat_conjugate(half), cubic))


def rotate_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q)^T v for quaternions q (..., n, 4) and vectors v (n, 3)."""
    w, u = q[..., :1], -q[..., 1:]               # conj(q) rotates by R^T
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def fit_carried_gravity(moves: list[MoveStream], B: np.ndarray, B_cov: np.ndarray, g0: np.ndarray,
                        g1: np.ndarray, scale: float,
                        gravity_source: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> CarriedFit:
    """H (from `scale` times I) carrying the unit gravity directions g0 onto g1 (n, 3) across `moves`, and its
    covariance (see the module). `gravity_source`: (dg0/dp, dg1/dp (n, 3, m) each, cov(p) (m, m)), the directions'
    sensitivity to the m parameters of the calibration they came from and that calibration's covariance."""
    ms = MoveSet.build(moves, B)
    n = len(moves)

    def rotations(X: np.ndarray, moveset: MoveSet) -> np.ndarray:
        """Quaternions (..., n, 4) of the motions for stacked H / scale, row-major (..., 9)."""
        return integrated_quats(X.reshape(X.shape[:-1] + (3, 3)) * scale, moveset)

    def residuals(X: np.ndarray, moveset: MoveSet) -> np.ndarray:
        return rotate_inverse(rotations(X, moveset), g0) - g1

    def jacobian(x: np.ndarray, step: float = 1e-7) -> np.ndarray:
        X = np.vstack([x, x + step * np.eye(9)])
        r = residuals(X, ms).reshape(10, -1)
        return ((r[1:] - r[0]) / step).T

    res = least_squares(lambda x: residuals(x, ms).ravel(), np.eye(3).ravel(), jac=jacobian, method="lm", xtol=1e-12,
                        ftol=1e-12, gtol=1e-12)
    J, r0 = res.jac, res.fun
    rank = int(np.linalg.matrix_rank(J))
    H = res.x.reshape(3, 3) * scale
    gain = -np.linalg.pinv(J.T @ J) @ J.T * scale                   # d vec(H) / d r
    var = float(r0 @ r0) / max(2 * n - 9, 1)
    fitted = var * (gain @ gain.T)

    D = np.stack([reading_disagreement(moves, B, H), step_doubling(moves, B, H)])       # (2, n, 3)
    q = rotations(res.x, ms)
    Jb = np.stack([(rotate_inverse(quat_multiply(q, quat_exp(-1e-3 * d)), g0) - g1).ravel() - r0
                   for d in D], axis=1) / 1e-3                     # d r / d (beta, gamma)
    projected = Jb - J @ np.linalg.lstsq(J, Jb, rcond=None)[0]     # what H cannot absorb of them
    told = projected.T @ projected / var + np.diag(1.0 / np.array(INTEGRATION_PRIOR_SD) ** 2)
    shares_cov = np.linalg.inv(told)
    shares = -shares_cov @ projected.T @ r0 / var
    dH = gain @ Jb                                                  # d vec(H) / d (beta, gamma)
    H = H + (dH @ shares).reshape(3, 3)
    r = r0 + projected @ shares
    reading_cov = dH @ shares_cov @ dH.T

    bias_cov = np.zeros((9, 9))
    sd = np.sqrt(np.clip(np.diag(B_cov), 0, None))
    if sd.any():
        JB = np.zeros((r0.size, 3))
        for k in np.flatnonzero(sd > 0):
            Bk = B.copy()
            Bk[k] += 1e-3 * sd[k]
            JB[:, k] = (residuals(res.x, MoveSet.build(moves, Bk)).ravel() - r0) / (1e-3 * sd[k])
        G = gain @ JB
        bias_cov = G @ B_cov @ G.T

    source_cov = np.zeros((9, 9))
    if gravity_source is not None:
        dg0, dg1, p_cov = gravity_source
        R_T = np.swapaxes(matrix_from_quat(q), -1, -2)
        G = gain @ (np.einsum("nij,njm->nim", R_T, dg0) - dg1).reshape(3 * n, -1)
        source_cov = G @ p_cov @ G.T
    return CarriedFit(H=H, H_cov=fitted + reading_cov + bias_cov + source_cov, residuals=r.reshape(n, 3),
                      iterations=int(res.nfev), converged=bool(res.success), rank=rank, reading_cov=reading_cov,
                      shares=shares, shares_sd=np.sqrt(np.diag(shares_cov)),
                      disagreement_rad=np.linalg.norm(D[0], axis=1))
