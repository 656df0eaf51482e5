"""Aggregate a session into the rows the discrepancy tests regress: hold means for every sensor and,
for the gyroscope, short windows of the moves.

Averaging to segments whitens the white noise and gives an honest row count (effects-research.md
section 2.2, step 3); each row keeps every covariate an effect of `effects.md` can follow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.calibration.numerics.quantisation import mean_standard_error
from rig.rotations import matrix_from_quat, rotvec_from_matrix
from rig.session_data import SessionData, mean_rotation



@dataclass
class Observations:
    """Rows of one sensor in time order (holds first, then move windows for the gyro)."""

    sensor: str
    is_move: np.ndarray      # (n,) bool
    y: np.ndarray            # (n, 3) mean raw counts
    rate_samples: np.ndarray  # (n, L, 3) reference rate of each sample of a row, NaN padded (0 at holds)
    sigma: np.ndarray        # (n, 3) standard error of y (counts)
    count: np.ndarray        # (n,)
    t: np.ndarray            # (n,) mid time, s
    t_start: np.ndarray
    t_end: np.ndarray
    temp: np.ndarray | None  # (n,) degC
    vsupply: np.ndarray | None
    R: np.ndarray            # (n, 3, 3) fixture -> world (mean)
    f: np.ndarray            # (n, 3) mean specific force, fixture frame, from the reference (level table)
    rate: np.ndarray         # (n, 3) mean reference body rate, rad/s (0 at holds)
    rate_dot: np.ndarray     # (n, 3) mean d(rate)/dt, rad/s^2
    outer_rate: np.ndarray   # (n,) mean outer-axis rate, rad/s
    angles: np.ndarray       # (n, 2) outer, inner, deg
    group: np.ndarray        # (n,) orientation index used for leave-one-orientation-out
    B0: np.ndarray           # (3,) mean of the holds (zero-rate level)

    @property
    def n(self) -> int:
        return len(self.t)

    def subset(self, keep: np.ndarray) -> "Observations":
        fields = {k: (v[keep] if isinstance(v, np.ndarray) and v.ndim >= 1 and len(v) == self.n and k != "B0" else v)
                  for k, v in self.__dict__.items()}
        return Observations(**fields)


def table_angles(R: np.ndarray) -> np.ndarray:
    """(outer, inner) deg of R = Rx(outer) Rz(inner) (conventions.md tumble table)."""
    inner = np.degrees(np.arctan2(-R[..., 0, 1], R[..., 0, 0]))
    outer = np.degrees(np.arctan2(-R[..., 1, 2], R[..., 2, 2]))
    return np.stack([outer, inner], -1)


def hold_observations(session: SessionData, sensor: str) -> Observations:
    h = session.holds(sensor)
    if len(h.step) == 0:
        raise ValueError(f"{session.source}: sensor {sensor!r} has no samples in any hold")
    sigma = mean_standard_error(np.nan_to_num(h.std, nan=0.0), h.count)
    g = np.array([0.0, 0.0, session.gravity])
    n = len(h.step)
    B0 = h.mean.mean(axis=0)
    return Observations(
        sensor=sensor, is_move=np.zeros(n, bool), y=h.mean, sigma=sigma,
        count=h.count, t=0.5 * (h.t_start + h.t_end), t_start=h.t_start, t_end=h.t_end,
        temp=_finite_or_none(h.temp_c), vsupply=_finite_or_none(h.vsupply_v), R=h.R,
        f=np.einsum("kji,j->ki", h.R, g), rate=np.zeros((n, 3)), rate_dot=np.zeros((n, 3)),
        outer_rate=np.zeros(n), angles=table_angles(h.R), group=h.step.astype(int), B0=B0,
        rate_samples=np.zeros((n, 1, 3)))


def _finite_or_none(x):
    return x if x is not None and np.all(np.isfinite(x)) else None


def reference_rates(session: SessionData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body rate (n, 3) rad/s from central differences of the reference attitude, its time derivative,
    and the rotation matrices (n, 3, 3)."""
    R = matrix_from_quat(session.q_ref)
    t = session.t
    lo = np.r_[0, np.arange(len(t) - 1)]
    hi = np.r_[np.arange(1, len(t)), len(t) - 1]
    dR = np.einsum("nji,njk->nik", R[lo], R[hi])
    rate = rotvec_from_matrix(dR) / (t[hi] - t[lo])[:, None]
    return rate, np.gradient(rate, t, axis=0), R


CORNER_RAD_S = 0.005   # 0.3 deg/s: second difference of the reference rate well above its quantisation noise


def acceleration_corners(rate: np.ndarray) -> np.ndarray:
    """Samples next to a jump of the table's acceleration (start, end of a ramp, apex of a triangular
    move). There the central-difference reference rate is off by up to accel * dt / 2 (1 deg/s at
    200 deg/s^2 and 100 Hz), an error even in the rate's sign that would pose as a scale asymmetry or
    a latency. Elsewhere the rate is linear in time (constant acceleration), so its second difference
    vanishes; samples where it does not, and their neighbours, are left out of the move windows."""
    e = np.zeros(len(rate))
    e[1:-1] = np.linalg.norm(rate[2:] - 2 * rate[1:-1] + rate[:-2], axis=1)
    corner = e > CORNER_RAD_S
    return corner | np.r_[False, corner[:-1]] | np.r_[corner[1:], False]


def gyro_observations(session: SessionData, sensor: str, *, window_s: float = 0.1) -> Observations:
    """Hold means plus move windows of `window_s` (the table's rate changes within ~0.1 s at most
    ramps' ends, so shorter windows keep the latency signal; longer ones would blur it)."""
    holds = hold_observations(session, sensor)
    rate, rate_dot, R = reference_rates(session)
    y_all = session.raw[sensor]
    have = np.isfinite(y_all).all(axis=1)
    per_sample = np.sqrt(np.median(holds.sigma ** 2 * holds.count[:, None], axis=0))
    ang_all = session.table_deg if session.table_deg is not None else table_angles(R)
    outer_rate_all = np.gradient(np.radians(ang_all[:, 0]), session.t)
    g = np.array([0.0, 0.0, session.gravity])
    rows = []
    move_idx = np.flatnonzero(session.is_move & have & ~acceleration_corners(rate))
    if move_idx.size:
        breaks = np.flatnonzero((np.diff(move_idx) != 1) | (np.diff(session.step[move_idx]) != 0)) + 1
        dt = np.median(np.diff(session.t))
        k = max(2, int(round(window_s / dt)))
        for seg in np.split(move_idx, breaks):
            for w in np.array_split(seg, max(1, len(seg) // k)):
                if len(w) >= 2:
                    rows.append(w)
    n = len(rows)
    B0 = holds.y.mean(axis=0)
    if n == 0:
        return holds
    y = np.array([y_all[w].mean(axis=0) for w in rows])
    Rm = np.array([mean_rotation(session.q_ref[w]) for w in rows])
    moves = Observations(
        sensor=sensor, is_move=np.ones(n, bool), y=y,
        sigma=per_sample / np.sqrt([len(w) for w in rows])[:, None], count=np.array([len(w) for w in rows]),
        t=np.array([session.t[w].mean() for w in rows]), t_start=np.array([session.t[w[0]] for w in rows]),
        t_end=np.array([session.t[w[-1]] for w in rows]),
        temp=None if holds.temp is None else np.array([np.mean(session.temp_c[w]) for w in rows]),
        vsupply=None if holds.vsupply is None else np.array([np.mean(session.vsupply_v[w]) for w in rows]),
        R=Rm, f=np.array([np.einsum("nji,j->ni", R[w], g).mean(axis=0) for w in rows]),
        rate=np.array([rate[w].mean(axis=0) for w in rows]), rate_dot=np.array([rate_dot[w].mean(axis=0) for w in rows]),
        outer_rate=np.array([outer_rate_all[w].mean() for w in rows]),
        angles=np.array([ang_all[w].mean(axis=0) for w in rows]),
        group=np.array([session.step[w[0]] for w in rows], dtype=int), B0=B0,
        rate_samples=_padded([rate[w] for w in rows]))
    return _concat(holds, moves)


def _padded(blocks: list[np.ndarray]) -> np.ndarray:
    out = np.full((len(blocks), max(len(b) for b in blocks), 3), np.nan)
    for i, b in enumerate(blocks):
        out[i, :len(b)] = b
    return out


def _concat(a: Observations, b: Observations) -> Observations:
    out = {}
    for k, v in a.__dict__.items():
        w = b.__dict__[k]
        if k in ("sensor", "B0"):
            out[k] = v
        elif v is None or w is None:
            out[k] = None
        elif k == "rate_samples":
            L = max(v.shape[1], w.shape[1])
            pad = lambda x: np.concatenate([x, np.full((x.shape[0], L - x.shape[1], 3), np.nan)], axis=1)  # noqa: E731
            out[k] = np.concatenate([pad(v), pad(w)])
        else:
            out[k] = np.concatenate([v, w])
    return Observations(**out)


def observations(session: SessionData, sensor: str) -> Observations:
    return gyro_observations(session, sensor) if sensor == "gyro" else hold_observations(session, sensor)
