"""Static intervals split where the gyro shows the unit turning (the accelerometer's detector cannot see it).

imu_tk's detector (`static_detect`) watches the accelerometer only. A turn about the vertical between two poses
leaves gravity along the same body axis, so the accelerometer stays still and the two poses and the turn become one
"static" interval; its gyro mean is then the turn's rate, and the motion it hides is lost to the gyro fit (the
synthetic hand session of seed 5, a 71 deg turn between two of 14 poses: gyro scale error 2.3e-3, 7.0e-4 with the
cut; seeds 1-8 without such a turn 2e-4 to 7e-4).

Within each interval the gyro's rate less the interval's median (the bias at that pose: a g-sensitive gyro's bias
moves from pose to pose by more than its noise) is averaged over centred windows of the detector's length; a
window whose mean rate departs by more than K times the initial rest's (the RMS over the rest's windows, less the
rest's median; the poses' where the record starts moving) shows a rotation, and its centre sample is not still.
Samples within half a window of the interval's ends take the nearest full window's verdict. The still runs left
are the intervals returned; where the gyro is as quiet as at rest nothing changes, and imu_tk's intervals stand.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.numerics.static_detect import window_samples

# A white-noise window mean has an RMS magnitude of the rest's level; K of it is a tail beyond 1e-20 (chi, 3 dof).
# imu_tk's Xsens poses reach 2.5 times their rest's level (a hand's tremor); a 71 deg turn over 2 s, 1100 times.
GYRO_K = 6.0


def window_means(x: np.ndarray, win: int) -> np.ndarray:
    """Means of the full windows of `win` rows of x (n, 3): (n - win + 1, 3)."""
    c = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)])
    return (c[win:] - c[:-win]) / win


def turning_threshold(t: np.ndarray, gyro: np.ndarray, *, window_s: float = 1.0, rest_rows: int = 0,
                      poses: list[tuple[int, int]] = (), k: float = GYRO_K) -> float:
    """K times the RMS magnitude of the quiet window means (less their stretch's median), in the gyro's units: those
    of the initial rest's first `rest_rows` rows where it holds a window, else the median over the `poses` (the
    accelerometer's static intervals) of each one's RMS (a record that starts moving; a hand's tremor puts a pose's
    level above a rest's, 2.5 times on imu_tk's Xsens poses, and a turn in a pose far above: 1100 times).

    A gyro too coarse to show its noise at rest (every window mean the median) is given its finest value step
    instead: a window whose mean is K steps off is a rotation for a gyro that rests within one."""
    gyro = np.asarray(gyro, dtype=float)
    win = window_samples(t, window_s)
    stretches = [gyro[:rest_rows]] if rest_rows >= win else [gyro[a:b + 1] for a, b in poses if b - a + 1 >= win]
    if not stretches:
        return float("inf")
    levels = []
    for y in stretches:
        means = window_means(y - np.median(y, axis=0), win)
        levels.append(float(np.sqrt(np.mean(np.sum(means * means, axis=1)))))
    level = float(np.median(levels))
    if level > 0:
        return k * level
    steps = [np.diff(np.unique(axis)) for axis in gyro.T]
    step = min((float(s[s > 0].min()) for s in steps if (s > 0).any()), default=float("inf"))
    return k * step


def split_turning(t: np.ndarray, gyro: np.ndarray, intervals: list[tuple[int, int]], threshold: float, *,
                  window_s: float = 1.0) -> list[tuple[int, int]]:
    """The intervals [(start, end)] (inclusive) cut into their runs that the gyro sees still (see the module)."""
    gyro = np.asarray(gyro, dtype=float)
    win = window_samples(t, window_s)
    h = win // 2
    out = []
    for a, b in intervals:
        n = b - a + 1
        if n < win:
            out.append((a, b))
            continue
        y = gyro[a:b + 1]
        rate = np.linalg.norm(window_means(y - np.median(y, axis=0), win), axis=1)
        busy = np.concatenate([np.full(h, rate[0]), rate, np.full(n - len(rate) - h, rate[-1])]) > threshold
        edges = np.diff(np.concatenate([[0], (~busy).astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        out += [(a + int(s), a + int(e)) for s, e in zip(starts, ends)]
    return out
