"""Where the accelerometer sits relative to the intersection of the table axes, and its effect removed.

Why: an accelerometer at position r (fixture frame, metres) from the axes' intersection measures, while
the table turns, the specific force

    f = R^T (G e_z) + w' x r + w x (w x r)                                        (rigid-body kinematics)

with w the body rate and w' its derivative. The still holds cannot see r, but an attitude filter reads
the two extra terms as tilt during every move. With R from the table's reference, `f - R^T G e_z` is
linear in r, so r follows from one linear least-squares fit over the move rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import chdtrc, fdtrc
from scipy.ndimage import uniform_filter1d

# The angular acceleration is a derivative of a noisy rate. Averaged over this span its noise shrinks
# (in the fit and in the compensated accelerometer) while a trapezoid's acceleration phases, hundreds
# of ms long, keep their shape.
SMOOTH_S = 0.04
# The two-sided tail of a normal beyond 3 sigma: significant = as unlikely as a 3-sigma deviation.
SIGNIFICANCE_P = 2.7e-3
# A gap in the fitted rows longer than this many sample periods starts a new move (a new cluster).
MOVE_GAP_PERIODS = 5.0


@dataclass
class LeverArm:
    r_m: np.ndarray        # (3,) accelerometer position in the fixture frame, m
    std_m: np.ndarray      # (3,) standard deviation of r_m, m
    rows_used: int
    significant: bool      # the Wald test rejects r = 0 at the 3-sigma level (p < SIGNIFICANCE_P)
    cov_m2: np.ndarray | None = None  # (3, 3)
    residual_rms: float = float("nan")  # m/s^2, per axis
    p_value: float = float("nan")


def skew_rows(v: np.ndarray) -> np.ndarray:
    """[v]x for each row of v (n, 3) -> (n, 3, 3)."""
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    o = np.zeros_like(x)
    return np.stack([np.stack([o, -z, y], -1), np.stack([z, o, -x], -1), np.stack([-y, x, o], -1)], -2)


def rate_and_derivative(t: np.ndarray, gyro: np.ndarray,
                        smooth_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Body rate and its time derivative on every row of t.

    The derivative is a central difference on the rows where the gyro has a sample (np.gradient, which
    allows uneven spacing), averaged over `smooth_s`; both are interpolated onto the rows without one.
    """
    t = np.asarray(t, dtype=float)
    gyro = np.asarray(gyro, dtype=float)
    have = np.isfinite(gyro).all(axis=1)
    if have.sum() < 3:
        raise ValueError(f"lever arm: the gyro has {int(have.sum())} samples; at least 3 are needed for a derivative")
    tg, wg = t[have], gyro[have]
    dw = np.gradient(wg, tg, axis=0)
    width = _width(tg, SMOOTH_S if smooth_s is None else smooth_s)
    if width > 1:
        dw = uniform_filter1d(dw, width, axis=0, mode="nearest")
    if have.all():
        return wg, dw
    interp = lambda a: np.column_stack([np.interp(t, tg, a[:, k]) for k in range(3)])  # noqa: E731
    return interp(wg), interp(dw)


def lever_arm_matrix(w: np.ndarray, dw: np.ndarray) -> np.ndarray:
    """A with A r = w' x r + w x (w x r): [w']x + [w]x[w]x, (n, 3, 3)."""
    W = skew_rows(w)
    return skew_rows(dw) + W @ W


def estimate_lever_arm(t: np.ndarray, accel: np.ndarray, gyro: np.ndarray, R_ref: np.ndarray, gravity: float,
                       rows: np.ndarray, groups: np.ndarray | None = None) -> LeverArm:
    """Least squares of `f - R^T (G e_z)` on `[w']x + [w]x[w]x` over `rows` (move rows where the
    accelerometer has a sample; the gyro is interpolated onto them where it has none).

    accel in m/s^2 and gyro in rad/s, both calibrated into the fixture frame; R_ref (n, 3, 3) fixture ->
    world. Both sides of the equation are averaged over SMOOTH_S alike: that keeps the relation exact
    (it is linear in r) while the noise of the differentiated gyro shrinks, where smoothing w' alone
    would bias r through the blurred acceleration steps of the moves. The covariance is cluster-robust
    with one cluster per move (`groups`, default: runs of rows without a time gap), because the residuals
    within a move are correlated and an ordinary sigma^2 (A^T A)^-1 would call a millimetre significant.
    """
    t = np.asarray(t, dtype=float)
    rows = np.asarray(rows, dtype=int)
    accel = np.asarray(accel, dtype=float)
    R_ref = np.asarray(R_ref, dtype=float)
    if len(rows) < 3:
        raise ValueError(f"lever arm: {len(rows)} move rows; at least 3 are needed")
    if not (np.isfinite(accel[rows]).all() and np.isfinite(R_ref[rows]).all()):
        raise ValueError("lever arm: rows must be rows where the accelerometer and the reference are finite")
    have = np.isfinite(accel).all(axis=1) & np.isfinite(R_ref).all(axis=(1, 2))
    w, dw = rate_and_derivative(t, gyro, smooth_s=0.0)
    A_all = lever_arm_matrix(w[have], dw[have])
    b_all = accel[have] - gravity * R_ref[have, 2, :]
    width = _width(t[have], SMOOTH_S)
    if width > 1:
        A_all = uniform_filter1d(A_all, width, axis=0, mode="nearest")
        b_all = uniform_filter1d(b_all, width, axis=0, mode="nearest")
    pick = np.searchsorted(np.flatnonzero(have), rows)
    A, b = A_all[pick].reshape(-1, 3), b_all[pick].reshape(-1)
    AtA = A.T @ A
    if np.linalg.cond(AtA) > 1e12:
        raise ValueError("lever arm: the moves do not turn about enough axes to locate the accelerometer")
    r = np.linalg.solve(AtA, A.T @ b)
    e = b - A @ r
    groups = _move_groups(t[rows]) if groups is None else np.asarray(groups)
    if groups.shape != rows.shape:
        raise ValueError(f"lever arm: groups has shape {groups.shape}, rows {rows.shape}; one move label per row")
    cov = _cluster_covariance(A, e, np.repeat(groups, 3), np.linalg.inv(AtA))
    p = _wald_p_value(r, cov, len(np.unique(groups)))
    return LeverArm(r, np.sqrt(np.diag(cov)), len(rows), bool(p < SIGNIFICANCE_P), cov,
                    float(np.sqrt(np.mean(e ** 2))), p)


def _wald_p_value(r: np.ndarray, cov: np.ndarray, clusters: int) -> float:
    """p of the Wald test of r = 0. With a cluster-robust covariance from G clusters, W/3 follows
    F(3, G-1) rather than chi^2(3)/3 (Cameron & Miller 2015): with ~20 moves the plain chi^2 test
    flags a tenth of a millimetre on a rig without a lever arm."""
    wald = float(r @ np.linalg.solve(cov, r))
    if clusters < 2:
        return float(chdtrc(3, wald))
    return float(fdtrc(3, clusters - 1, wald / 3.0))


def _width(t: np.ndarray, span_s: float) -> int:
    """An odd number of samples covering about span_s."""
    return int(round(span_s / float(np.median(np.diff(t))))) | 1


def compensate(t: np.ndarray, accel: np.ndarray, gyro: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The accelerometer as if it sat at the intersection of the axes: f - (w' x r + w x (w x r)).

    Rows without an accelerometer sample stay NaN.
    """
    accel = np.asarray(accel, dtype=float)
    w, dw = rate_and_derivative(t, gyro)
    r = np.asarray(r, dtype=float)
    return accel - (np.cross(dw, r) + np.cross(w, np.cross(w, r)))


def _move_groups(t_rows: np.ndarray) -> np.ndarray:
    dt = np.diff(t_rows)
    if not len(dt):
        return np.zeros(len(t_rows), dtype=int)
    return np.concatenate([[0], np.cumsum(dt > MOVE_GAP_PERIODS * np.median(dt))])


def _cluster_covariance(A: np.ndarray, e: np.ndarray, groups: np.ndarray, AtA_inv: np.ndarray) -> np.ndarray:
    """Cluster-robust sandwich covariance with the usual small-sample factor G/(G-1) (N-1)/(N-K) (the
    "CR1" estimator, Cameron & Miller 2015); with one cluster it falls back to sigma^2 (A^T A)^-1."""
    labels = np.unique(groups)
    n, k = A.shape
    if len(labels) < 2:
        return float(e @ e) / max(n - k, 1) * AtA_inv
    scores = np.array([A[groups == g].T @ e[groups == g] for g in labels])
    meat = scores.T @ scores
    c = len(labels) / (len(labels) - 1) * (n - 1) / max(n - k, 1)
    return c * AtA_inv @ meat @ AtA_inv
