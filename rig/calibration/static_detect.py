"""Static-interval detection the way imu_tk does it (Tedaldi et al., ICRA 2014; `staticIntervalsDetector`).

A sample is static when the norm of the per-axis variance of the accelerometer over a centred
window (101 samples at 100 Hz) is below k times the same norm over the initial static interval
the user is asked to record. Consecutive static samples form an interval. imu_tk sweeps k = 2..10
and keeps the k whose calibration has the least cost; `turntable_free` does the same.
"""

from __future__ import annotations

import numpy as np

SAMPLES_PER_INTERVAL = 100  # imu_tk's interval_n_samples: what a static interval must hold to be used


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
