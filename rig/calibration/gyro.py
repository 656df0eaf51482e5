"""Gyroscope calibration against known rig rotations (Zhang et al., IEEE TIE 62(6) 2015, section II.C).

Model: `omega = H (y - B)` (conventions.md). B is the mean of the stationary holds (eq. 41); H is the
3x3 matrix for which the rate integrated over every move reproduces the rotation the table made,
`Int(H (y - B)) = R_j^T R_{j+1}` (eqs. 52-55 for Int). The paper estimates H with an unscented
Kalman filter whose state is the nine entries of H with a random-walk process (eqs. 44-45).

Equation numbers follow the brief; the paper's text could not be retrieved here, so the
measurement is our reconstruction: per move, the rotation vector of `R_known^T R_int(H)`, whose
expected value is zero. Using the rotation error (not Euler angles or a quaternion difference)
keeps the measurement 3-dimensional, smooth at the solution and free of sign ambiguity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from scipy.optimize import minimize_scalar

from rig.calibration.integrate import ordered_product, quat_exp
from rig.calibration.result import TriadCalibration
from rig.rotations import quat_from_matrix
from rig.session_data import MoveStream


def gyro_bias(hold_means: np.ndarray, counts: np.ndarray | None = None) -> np.ndarray:
    """Eq. 41: the gyro bias is the mean raw output while the table is still (earth rate ignored).

    Holds are weighted by their sample counts so long holds count for what they measured.
    """
    means = np.asarray(hold_means, dtype=float).reshape(-1, 3)
    if means.shape[0] == 0:
        raise ValueError("gyro_bias: no stationary holds given")
    w = np.ones(len(means)) if counts is None else np.asarray(counts, dtype=float).ravel()
    if w.shape != (len(means),) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"gyro_bias: counts must be {len(means)} non-negative numbers with a positive sum, got {w!r}")
    return (w[:, None] * means).sum(axis=0) / w.sum()


@dataclass
class MoveSet:
    """The moves' raw data reduced to what the Magnus step needs, padded to one length.

    With linear rates the interval rotation vector is `phi = h/2 (w0 + w1) + h^2/12 (w0 x w1)`; for
    `w = H u` this is `S H^T + C cof(H)^T` with `S = h/2 (u0 + u1)` and `C = h^2/12 (u0 x u1)` fixed by
    the data, because `(H a) x (H b) = cof(H) (a x b)`. Padding intervals have S = C = 0 (identity).
    """

    S: np.ndarray          # (n, L, 3) counts * s
    C: np.ndarray          # (n, L, 3) counts^2 * s^2
    h: np.ndarray          # (n, L) interval lengths, s (0 for padding)
    q_known: np.ndarray    # (n, 4) R_j^T R_{j+1}
    steps: list[int]

    @classmethod
    def build(cls, moves: list[MoveStream], B: np.ndarray) -> "MoveSet":
        if not moves:
            raise ValueError("gyro calibration: no moves given")
        B = np.asarray(B, dtype=float).reshape(3)
        lengths = []
        for mv in moves:
            if len(mv.t) < 2 or mv.y.shape != (len(mv.t), 3):
                raise ValueError(f"move after hold {mv.step}: need >= 2 samples of 3 axes, got t {np.shape(mv.t)}, y {np.shape(mv.y)}")
            if not np.all(np.isfinite(mv.y)):
                raise ValueError(f"move after hold {mv.step}: raw gyro samples contain NaN/inf")
            if np.any(np.diff(mv.t) <= 0):
                raise ValueError(f"move after hold {mv.step}: time stamps do not increase")
            lengths.append(len(mv.t) - 1)
        n, L = len(moves), max(lengths)
        S, C, hs = np.zeros((n, L, 3)), np.zeros((n, L, 3)), np.zeros((n, L))
        for i, mv in enumerate(moves):
            u = np.asarray(mv.y, dtype=float) - B
            h = np.diff(np.asarray(mv.t, dtype=float))[:, None]
            hs[i, :lengths[i]] = h[:, 0]
            S[i, :lengths[i]] = 0.5 * h * (u[:-1] + u[1:])
            C[i, :lengths[i]] = (h * h / 12.0) * np.cross(u[:-1], u[1:])
        q_known = quat_from_matrix(np.array([mv.known_rotation for mv in moves]))
        return cls(S, C, hs, np.atleast_2d(q_known), [int(mv.step) for mv in moves])

    def subset(self, i: int) -> "MoveSet":
        return MoveSet(self.S[i:i + 1], self.C[i:i + 1], self.h[i:i + 1], self.q_known[i:i + 1], self.steps[i:i + 1])


def cofactor(H: np.ndarray) -> np.ndarray:
    """cof(H) = det(H) H^-T for a stack (..., 3, 3), from row cross products."""
    r0, r1, r2 = H[..., 0, :], H[..., 1, :], H[..., 2, :]
    return np.stack([np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)], axis=-2)


def integrated_quats(H: np.ndarray, ms: MoveSet) -> np.ndarray:
    """Int(H (y - B)) for every move, as quaternions (..., n, 4), for a stack of H (..., 3, 3)."""
    H = np.asarray(H, dtype=float)
    Ht = np.swapaxes(H, -1, -2)[..., None, :, :]
    Ct = np.swapaxes(cofactor(H), -1, -2)[..., None, :, :]
    phi = ms.S @ Ht + ms.C @ Ct
    return ordered_product(quat_exp(phi))


def rotation_residuals(H: np.ndarray, ms: MoveSet) -> np.ndarray:
    """Rotation vectors of R_known^T R_int(H) per move (..., n, 3), angle in [0, pi] (eq. 43 terms)."""
    q = integrated_quats(H, ms)
    k = ms.q_known * np.array([1.0, -1.0, -1.0, -1.0])
    w = k[..., 0] * q[..., 0] + np.einsum("...i,...i->...", k[..., 1:], q[..., 1:])
    v = k[..., :1] * q[..., 1:] + q[..., :1] * k[..., 1:] + np.cross(k[..., 1:], q[..., 1:])
    sign = np.where(w < 0, -1.0, 1.0)
    w, v = w * sign, v * sign[..., None]
    sn = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(sn, w)
    scale = np.where(sn > 1e-12, angle / np.where(sn > 1e-12, sn, 1.0), 2.0 / np.maximum(w, 1e-300))
    return v * scale[..., None]


def nominal_scale(ms: MoveSet, *, min_rate_dps: float = 1.0, max_rate_dps: float = 3000.0) -> float:
    """A scalar s so that H0 = s I integrates closest to the known rotations: the UKF's start point.

    The cost over s has one basin per winding of each move, so a log grid (5 % steps, coarse
    enough to be cheap, fine enough for basins about +-50 % wide) covering peak body rates of
    `min_rate_dps`..`max_rate_dps` is searched first and the best cell refined.
    """
    mean_rates = np.linalg.norm(ms.S, axis=-1) / np.where(ms.h > 0, ms.h, np.inf)
    peak = float(mean_rates.max())
    if not np.isfinite(peak) or peak <= 0:
        raise ValueError("gyro calibration: the moves show no rotation (raw rates equal the bias)")
    lo, hi = np.radians(min_rate_dps) / peak, np.radians(max_rate_dps) / peak
    return scalar_search(lambda s: _scalar_cost(s, ms), lo, hi)


def scalar_search(cost_batch, lo: float, hi: float, step: float = 1.05) -> float:
    """Minimise cost_batch(s) (vectorised over s) on a log grid, then refine in the best cell."""
    grid = np.exp(np.arange(np.log(lo), np.log(hi) + np.log(step), np.log(step)))
    costs = np.concatenate([cost_batch(chunk) for chunk in np.array_split(grid, max(1, len(grid) // 16))])
    i = int(np.argmin(costs))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    res = minimize_scalar(lambda s: float(cost_batch(np.array([s]))[0]), bounds=(a, b), method="bounded",
                          options={"xatol": 1e-6 * grid[i]})
    return float(res.x) if res.fun <= costs[i] else float(grid[i])


def _scalar_cost(s: np.ndarray, ms: MoveSet) -> np.ndarray:
    H = np.asarray(s, dtype=float)[:, None, None] * np.eye(3)
    r = rotation_residuals(H, ms)
    return np.sum(r * r, axis=(-1, -2))


def _moves_rms(H: np.ndarray, ms: MoveSet) -> tuple[float, np.ndarray]:
    r = rotation_residuals(H, ms)
    per_move = np.linalg.norm(r, axis=-1)
    return float(np.sqrt(np.mean(per_move ** 2))), per_move


def calibrate_gyro_ukf(moves: list[MoveStream], B: np.ndarray, *, H0: np.ndarray | None = None,
                       noise_rad: float | None = None, max_passes: int = 30, tol: float = 1e-10,
                       prior_rel_std: float = 0.1, process_rel_std: float = 0.0,
                       history: list | None = None) -> TriadCalibration:
    """Gyro H by the UKF of eqs. 44-45 over the moves, repeated in passes until H stops changing.

    State: vec(H) (row-major) divided by s = |det H0|^(1/3), so the filter works on numbers of order 1.
    Process: random walk x_k = x_{k-1} + w, w ~ N(0, process_rel_std^2 I) (0 for a constant sensor).
    Measurement per move: z = rotvec(R_known^T Int(H (y - B))) = 0 + v, v ~ N(0, noise_rad^2 I).
    All sigma points of one move are integrated in one vectorised call. Each pass restarts from
    the previous pass's H with the prior covariance (prior_rel_std of s per entry), so the final
    covariance is that of one pass over the data, i.e. not over-confident from reusing it.
    If noise_rad is None it is re-estimated before each pass from the rms move residual.
    """
    ms = MoveSet.build(moves, B)
    if H0 is None:
        H0 = nominal_scale(ms) * np.eye(3)
    H = np.asarray(H0, dtype=float).reshape(3, 3)
    s = abs(np.linalg.det(H)) ** (1.0 / 3.0)
    if not s > 0:
        raise ValueError(f"calibrate_gyro_ukf: H0 is singular: {H.tolist()}")
    points = MerweScaledSigmaPoints(9, alpha=0.3, beta=2.0, kappa=0.0)
    ukf = UnscentedKalmanFilter(dim_x=9, dim_z=3, dt=1.0, fx=lambda x, dt: x, hx=None, points=points)
    ukf.Q = np.eye(9) * process_rel_std ** 2
    passes, converged, noise_used = 0, False, noise_rad
    for passes in range(1, max_passes + 1):
        if noise_rad is None:
            noise_used = max(_moves_rms(H, ms)[0], 1e-9)
        ukf.x = H.ravel() / s
        ukf.P = np.eye(9) * prior_rel_std ** 2
        ukf.R = np.eye(3) * noise_used ** 2
        for i in range(len(ms.steps)):
            _ukf_move_update(ukf, ms.subset(i), s)
        H_new = ukf.x.reshape(3, 3) * s
        change = np.linalg.norm(H_new - H) / np.linalg.norm(H_new)
        H = H_new
        if history is not None:
            history.append(H.copy())
        if change < tol:
            converged = True
            break
    return _result(H, B, ms, ukf.P * s * s, "gyro-ukf", passes, converged,
                   {"noise_rad": float(noise_used), "moves": len(ms.steps)})


def _ukf_move_update(ukf: UnscentedKalmanFilter, one: MoveSet, s: float) -> None:
    ukf.predict()
    z_sigma = rotation_residuals(ukf.sigmas_f.reshape(-1, 3, 3) * s, one)[:, 0, :]
    rows = iter(z_sigma)
    ukf.update(np.zeros(3), hx=lambda _x: next(rows))
    ukf.P = 0.5 * (ukf.P + ukf.P.T)


def _result(H: np.ndarray, B: np.ndarray, ms: MoveSet, H_cov: np.ndarray, method: str, iterations: int, converged: bool,
            extra: dict) -> TriadCalibration:
    rms, per_move = _moves_rms(H, ms)
    warnings = []
    if np.linalg.det(H) <= 0:
        warnings.append(f"det(H) = {np.linalg.det(H):.3g} <= 0: a mirrored gyro axis or a failed fit")
    if not converged:
        warnings.append(f"{method}: not converged after {iterations} iterations")
    H_cov = 0.5 * (H_cov + H_cov.T)
    extra = dict(extra, residual_rad_per_move=per_move.tolist())
    return TriadCalibration(B=np.asarray(B, dtype=float).reshape(3).copy(), H=H, method=method, residual_rms=rms, iterations=iterations, converged=converged,
                            H_std=np.sqrt(np.clip(np.diag(H_cov), 0, None)).reshape(3, 3), H_cov=H_cov,
                            warnings=warnings, extra=extra)
