"""Static-interval detection the way imu_tk does it (Tedaldi et al., ICRA 2014; `staticIntervalsDetector`).

A sample is static when the norm of the per-axis variance of the accelerometer over a centred
window (101 samples at 100 Hz) is below k times the same norm over the initial static interval
the user is asked to record. Consecutive static samples form an interval. imu_tk sweeps k = 2..10
and keeps the k whose calibration has the least cost; `turntable_free` does the same.

imu_tk takes the initial interval's length from its user (50 s). Here the data say it (`find_initial_rest`): the
still stretch the record starts with, judged against the quietest stretches of the whole record, so that a log
that rests 7 s or 50 s needs no option; a record that starts moving takes its static threshold from those
quietest stretches instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SAMPLES_PER_INTERVAL = 100  # imu_tk's interval_n_samples: what a static interval must hold to be used
QUIET_PERCENTILE = 10.0     # the quiet level of a record: this percentile of its windows' variance norms. A
# multi-position record is mostly poses; the level then lies among its stillest windows (imu_tk's Xsens record 0.8
# of its initial rest's, mikoff's MPU-9150 0.6, tomisuarez2's MPU-6050 0.9).
REST_K = 10.0               # a window of the record's start is still below this many times the quiet level: rests
# read 0.8-2 times it, the first motion of every recording here thousands of times from its first windows
MIN_REST_WINDOWS = 2        # an initial rest shorter than two windows is no rest: the record starts moving


def window_samples(t: np.ndarray, window_s: float) -> int:
    """Odd window length for `window_s` at the median sample rate (101 for 1 s at 100 Hz, as imu_tk)."""
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        raise ValueError("static detection: time stamps do not increase")
    n = max(int(round(window_s / dt)), 11)
    return n if n % 2 else n + 1


def initial_interval(t: np.ndarray, init_static_s: float) -> int:
    """Number of samples in the initial static interval: those with t - t0 < init_static_s (at least 2)."""
    n = int(np.searchsorted(t - t[0], init_static_s, side="left"))
    return max(min(n, len(t)), 2)


@dataclass(frozen=True)
class InitialRest:
    """The still stretch a record starts with: its rows `[0, rows)` (none: 0), where that came from ("given": the
    user's `--initial-rest-s`; "found": in the data; "none": the record starts moving) and the accelerometer's
    variance norm that imu_tk's static threshold multiplies (the rest's, or the record's quiet level)."""

    rows: int
    seconds: float
    origin: str
    accel_level: float

    @property
    def found(self) -> bool:
        return self.rows > 0

    def describe(self) -> str:
        if self.origin == "given":
            return f"initial rest {self.seconds:.3g} s (as the recording says)"
        if self.origin == "found":
            return f"initial rest {self.seconds:.3g} s found in the data"
        return "no initial rest (the record starts moving)"

    def to_extra(self) -> dict:
        return {"initial_rest_s": self.seconds, "initial_rest": self.origin}


def quiet_level(x: np.ndarray, win: int) -> float:
    """The variance norm of a record's quietest stretches (QUIET_PERCENTILE of its windows'); at least the variance
    of one value step (a stream too coarse to show its noise reads 0 in its still windows)."""
    norm = moving_variance_norm(x, win)
    level = float(np.nanpercentile(norm, QUIET_PERCENTILE)) if np.isfinite(norm).any() else 0.0
    return max(level, finest_step_variance(x))


def finest_step_variance(x: np.ndarray) -> float:
    """The variance norm of a flicker of one value step on every axis (a uniform quantisation error's step^2/12)."""
    steps = [np.diff(np.unique(axis)) for axis in np.asarray(x, dtype=float).T]
    step = min((float(s[s > 0].min()) for s in steps if (s > 0).any()), default=0.0)
    return float(np.sqrt(3.0) * step * step / 12.0)


def find_initial_rest(t: np.ndarray, accel: np.ndarray, gyro: np.ndarray | None = None, *, window_s: float = 1.0,
                      given_s: float | None = None) -> InitialRest:
    """The initial rest of a record: `given_s` seconds where the user says it (imu_tk's way), else the run of
    still windows the record starts with.

    A window is still when the accelerometer's variance norm is below REST_K times the record's quiet level
    (`quiet_level`) and, within that run, the gyro's is below REST_K times the run's median (the gyro sees a turn
    about the vertical that leaves the accelerometer still; its own quiet level is not the reference, since a gyro
    may be noisier in its first seconds than after, as the MPU-9150 of mikoff's log is, 70-260 times). The rest
    ends at the first window that is not, which keeps half a window clear of the first motion. Shorter than
    MIN_REST_WINDOWS windows, the record starts moving: the static threshold then takes the quiet level of the
    whole record."""
    t = np.asarray(t, dtype=float)
    accel = np.asarray(accel, dtype=float)
    if given_s is not None:
        rows = initial_interval(t, given_s)
        return InitialRest(rows, float(given_s), "given", float(np.linalg.norm(accel[:rows].var(axis=0, ddof=1))))
    win = window_samples(t, window_s)
    if win >= len(t):
        return InitialRest(0, 0.0, "none", float(np.linalg.norm(accel.var(axis=0, ddof=1))))
    level = quiet_level(accel, win)
    h = win // 2
    busy = ~(np.nan_to_num(moving_variance_norm(accel, win), nan=np.inf) < REST_K * level)
    end = h + int(np.argmax(busy[h:])) if busy[h:].any() else len(t) - h
    if gyro is not None and end > h:
        g = moving_variance_norm(np.asarray(gyro, dtype=float), win)[h:end]
        g_level = max(float(np.median(g)), finest_step_variance(gyro))
        turning = g > REST_K * g_level
        if turning.any():
            end = h + int(np.argmax(turning))
    if end < MIN_REST_WINDOWS * win:
        return InitialRest(0, 0.0, "none", level)
    return InitialRest(end, float(t[end] - t[0]), "found", float(np.linalg.norm(accel[:end].var(axis=0, ddof=1))))


def moving_variance_norm(x: np.ndarray, win: int) -> np.ndarray:
    """|var| of the centred windows of x (n, 3) (ddof = 1, as imu_tk); NaN within win//2 of the ends."""
    x = np.asarray(x, dtype=float)
    xc = x - x.mean(axis=0)
    c1 = np.vstack([np.zeros((1, 3)), np.cumsum(xc, axis=0)])
    c2 = np.vstack([np.zeros((1, 3)), np.cumsum(xc * xc, axis=0)])
    s1 = c1[win:] - c1[:-win]
    s2 = c2[win:] - c2[:-win]
    var = np.clip((s2 - s1 * s1 / win) / (win - 1), 0.0, None)
    out = np.full(len(x), np.nan)
    h = win // 2
    out[h:len(x) - h] = np.linalg.norm(var, axis=1)
    return out


def detect_static_intervals(t: np.ndarray, accel: np.ndarray, *, window_s: float = 1.0, init_static_s: float = 50.0,
                            k: float = 6.0, threshold: float | None = None) -> list[tuple[int, int]]:
    """Static index ranges [(start, end)] (inclusive) of an accelerometer record.

    The threshold is k times the variance norm of the first `init_static_s` seconds unless given.
    """
    t = np.asarray(t, dtype=float)
    accel = np.asarray(accel, dtype=float)
    if t.ndim != 1 or accel.shape != (len(t), 3):
        raise ValueError(f"static detection: need t (n,) and accel (n, 3), got {t.shape} and {accel.shape}")
    win = window_samples(t, window_s)
    if win >= len(t):
        return []
    if threshold is None:
        n0 = initial_interval(t, init_static_s)
        threshold = k * float(np.linalg.norm(accel[:n0].var(axis=0, ddof=1)))
    norm = moving_variance_norm(accel, win)
    static = np.nan_to_num(norm, nan=np.inf) < threshold
    edges = np.diff(np.concatenate([[0], static.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(int(a), int(b)) for a, b in zip(starts, ends)]


def first_samples(intervals: list[tuple[int, int]], n_samples: int = SAMPLES_PER_INTERVAL) -> list[tuple[int, int]]:
    """The first `n_samples` of each interval longer than that (imu_tk's extractIntervalsSamples).

    imu_tk keeps an interval when end - start >= n_samples and fits its first n_samples samples.
    """
    return [(a, a + n_samples - 1) for a, b in intervals if b - a >= n_samples]


def long_intervals(intervals: list[tuple[int, int]], n_samples: int = SAMPLES_PER_INTERVAL) -> list[tuple[int, int]]:
    """The intervals imu_tk keeps (end - start >= n_samples), whole: the gyro step uses their means."""
    return [(a, b) for a, b in intervals if b - a >= n_samples]
