"""Each sensor's latency against the sample stamps, estimated from the reference and removed.

Why: a digital chip samples on its own timer and the rig reads its latest sample, so a row's value is
older than the row's stamp by up to one of the chip's sample periods (on the sim rig the sampler locks
its ticks to the ITG-3200's samples, ~0; the 50 Hz HMC5843's are ~10 ms old). At 130 deg/s, 5 ms is 0.65 deg: more than every other error of
the validation together. Like the constant frame rotation, this is a nuisance of the comparison that
the reference can measure, so it is estimated, reported and removed:

* gyro: the delay that best matches the calibrated rate to the reference body rate `Log(R_k^T R_k+1)/dt`;
  the gyro is then re-read at `t + delay`.
* accelerometer, magnetometer: the delay `d` for which the sample, put in the world frame with the
  reference at `t - d`, best matches the world vector (gravity, field) of the still interval; the sample
  is then carried forward over `d` with the gyro, `x(t) = Exp(-w d) x(t - d)`, which stays exact at the
  magnetometer's lower rate where interpolating between its samples would not.
"""

from __future__ import annotations

import numpy as np

from scipy.spatial.transform import Rotation, Slerp

from rig.rotations import matrix_from_quat, matrix_from_rotvec, rotvec_from_matrix


def reference_body_rates(t: np.ndarray, q_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(interval midpoints, body rates rad/s in the fixture frame) from reference quaternions."""
    R = matrix_from_quat(q_ref)
    rel = np.einsum("nji,njk->nik", R[:-1], R[1:])
    return 0.5 * (t[1:] + t[:-1]), rotvec_from_matrix(rel) / np.diff(t)[:, None]


def at_times(t: np.ndarray, x: np.ndarray, t_new: np.ndarray) -> np.ndarray:
    """Linear interpolation of the finite rows of x (n, 3) at t_new."""
    ok = np.isfinite(x).all(axis=1)
    return np.column_stack([np.interp(t_new, t[ok], x[ok, i]) for i in range(3)])


def estimate_gyro_delay(t: np.ndarray, gyro: np.ndarray, q_ref: np.ndarray, rows: np.ndarray, *,
                        max_periods: float = 2.0, resolution: int = 100) -> float:
    """Delay (s) of the gyro behind the stamps: rate(t) is best read as gyro(t + delay).

    Searched within +-max_periods sample periods to 1/resolution of a period (`_search`), over the
    intervals between consecutive `rows` (the moving part of the record).
    """
    t = np.asarray(t, dtype=float)
    rows = np.asarray(rows)
    t_mid, w_ref = reference_body_rates(t[rows], np.asarray(q_ref)[rows])
    keep = np.diff(rows) == 1
    t_mid, w_ref = t_mid[keep], w_ref[keep]
    if len(t_mid) < 10 or not np.any(np.linalg.norm(w_ref, axis=1) > 1e-3):
        return 0.0
    period = float(np.median(np.diff(t)))
    return _search(lambda d: float(np.mean((at_times(t, gyro, t_mid + d) - w_ref) ** 2)), max_periods * period,
                   period / resolution)


def _search(cost, half_width: float, resolution: float, points: int = 21) -> float:
    """Minimum of a one-dimensional cost on [-half_width, half_width]: grids of `points` that zoom in on
    the best point until their step is below `resolution`, then a parabola through the last three."""
    lo, hi = -half_width, half_width
    while True:
        grid = np.linspace(lo, hi, points)
        c = np.array([cost(d) for d in grid])
        i = int(np.clip(np.argmin(c), 1, points - 2))
        step = grid[1] - grid[0]
        if step <= resolution:
            c0, c1, c2 = c[i - 1:i + 2]
            curv = c0 - 2 * c1 + c2
            return float(grid[i] + (0.5 * step * (c0 - c2) / curv if curv > 0 else 0.0))
        lo, hi = grid[i - 1], grid[i + 1]


def estimate_vector_delay(t: np.ndarray, x: np.ndarray, q_ref: np.ndarray, still_rows: np.ndarray,
                          rows: np.ndarray, *, max_periods: float = 2.0, resolution: int = 100) -> float:
    """Delay (s) of an accelerometer or magnetometer behind the stamps (see the module docstring).

    The search spans +-max_periods of the sensor's own period (its rows with a sample).
    """
    t = np.asarray(t, dtype=float)
    have = np.isfinite(x).all(axis=1)
    still, rows = np.asarray(still_rows), np.asarray(rows)
    still, rows = still[have[still]], rows[have[rows]]
    if len(still) < 3 or len(rows) < 10:
        return 0.0
    unit = x / np.linalg.norm(x, axis=1, keepdims=True)
    R = matrix_from_quat(q_ref)
    v_world = np.einsum("nij,nj->i", R[still], unit[still])
    v_world /= np.linalg.norm(v_world)
    slerp = Slerp(t, Rotation.from_quat(np.asarray(q_ref), scalar_first=True))
    period = float(np.median(np.diff(t[have])))
    tr, ur = t[rows], unit[rows]

    def cost(d: float) -> float:
        Rd = slerp(np.clip(tr - d, t[0], t[-1])).as_matrix()
        return float(np.mean(np.sum((np.einsum("nij,nj->ni", Rd, ur) - v_world) ** 2, axis=1)))

    return _search(cost, max_periods * period, period / resolution)


def carried_forward(t: np.ndarray, x: np.ndarray, gyro: np.ndarray, delay_s: float) -> np.ndarray:
    """Samples of a body-frame vector taken `delay_s` before their stamps, rotated to the stamp times
    with the (latency-free) gyro: x(t) = Exp(-w(t - d/2) d) x(t - d). Rows without a sample stay NaN."""
    if delay_s == 0.0:
        return x
    have = np.isfinite(x).all(axis=1)
    out = np.array(x, dtype=float)
    w = at_times(t, gyro, np.asarray(t)[have] - 0.5 * delay_s)
    out[have] = np.einsum("nji,nj->ni", matrix_from_rotvec(w * delay_s), x[have])
    return out


def delayed(t: np.ndarray, gyro: np.ndarray, delay_s: float) -> np.ndarray:
    """The gyro re-read at `t + delay_s` (rows without a sample stay NaN)."""
    if delay_s == 0.0:
        return gyro
    out = at_times(t, gyro, np.asarray(t) + delay_s)
    out[~np.isfinite(gyro).all(axis=1)] = np.nan
    return out
