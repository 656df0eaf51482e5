"""Where a recording is still: its motion found in blocks of about a second, and its longest still stretch.

A block moves where any axis of any sensor spreads within it by more than `MOVING` times that axis's quiet spread
(the 10th percentile of its blocks', or its step where the counts hardly change): a hand, a bump or a turn shakes
a block as white noise, a flicker floor or a slow warm-up do not. A still stretch is a run of blocks none of which
moves; `rig noise --window still` analyses the longest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BLOCK_S = 1.0
MIN_BLOCK_SAMPLES = 16
MOVING = 4.0
QUIET_PERCENTILE = 10


@dataclass
class Motion:
    moving: np.ndarray          # (blocks,) bool
    edges: np.ndarray           # (blocks + 1,) row index where each block starts, and the end
    where: tuple[str, str] | None      # (sensor, axis) that moves most, if any moves

    def spans(self, t: np.ndarray) -> list[tuple[float, float]]:
        """(start, end) in the times t of each run of moving blocks."""
        out = []
        runs = _runs(self.moving)
        for a, b in runs:
            out.append((float(t[self.edges[a]]), float(t[self.edges[b] - 1])))
        return out


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(first, past the last) of each run of True."""
    padded = np.r_[False, flags, False].astype(np.int8)
    d = np.diff(padded)
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def block_edges(n: int, rate_hz: float) -> np.ndarray:
    size = max(MIN_BLOCK_SAMPLES, int(round(BLOCK_S * rate_hz)))
    edges = np.arange(0, n, size)
    return np.r_[edges, n] if n - edges[-1] >= size // 2 or len(edges) == 1 else np.r_[edges[:-1], n]


def motion(streams: dict[str, np.ndarray], rate_hz: float) -> Motion:
    """The blocks that move in `streams` ({sensor: (n, 3)}, rows sampled together at rate_hz)."""
    n = len(next(iter(streams.values())))
    edges = block_edges(n, rate_hz)
    moving = np.zeros(len(edges) - 1, dtype=bool)
    worst, where = 0.0, None
    for sensor, y in streams.items():
        for k, axis in enumerate("xyz"):
            spread = _spreads(y[:, k], edges)
            quiet = _quiet(y[:, k], spread)
            if not quiet > 0:
                continue
            ratio = spread / quiet
            moving |= np.nan_to_num(ratio) > MOVING
            if np.nanmax(ratio, initial=0.0) > worst:
                worst, where = float(np.nanmax(ratio)), (sensor, axis)
    return Motion(moving, edges, where if moving.any() else None)


def _spreads(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The standard deviation of the finite samples of each block (NaN where fewer than two), from the blocks'
    sums (numpy's reduceat), so that hours of samples cost no loop over their blocks."""
    finite = np.isfinite(x)
    v = np.where(finite, x, 0.0)
    starts = edges[:-1]
    count = np.add.reduceat(finite.astype(float), starts)
    mean = np.add.reduceat(v, starts) / np.maximum(count, 1)
    centred = np.where(finite, v - np.repeat(mean, np.diff(edges)), 0.0)
    var = np.add.reduceat(centred ** 2, starts) / np.maximum(count, 1)
    return np.where(count > 1, np.sqrt(var), np.nan)


def _quiet(x: np.ndarray, spread: np.ndarray) -> float:
    """An axis's spread within a block where it is quiet: the 10th percentile of its blocks', at least its step."""
    finite = spread[np.isfinite(spread)]
    level = float(np.percentile(finite, QUIET_PERCENTILE)) if finite.size else 0.0
    steps = np.abs(np.diff(x[np.isfinite(x)]))
    steps = steps[steps > 0]
    return max(level, float(steps.min()) if steps.size else 0.0)


def longest_still(streams: dict[str, np.ndarray], rate_hz: float) -> tuple[int, int] | None:
    """(first row, past the last row) of the longest run of blocks that do not move, or None where every block
    moves. Both ends are kept a block away from a moving block: a motion starts and ends within its blocks."""
    found = motion(streams, rate_hz)
    still = ~found.moving
    runs = _runs(still)
    if not runs:
        return None
    a, b = max(runs, key=lambda r: found.edges[r[1]] - found.edges[r[0]])
    if a > 0:
        a = min(a + 1, b)
    if b < len(still):
        b = max(b - 1, a)
    if b <= a:
        return None
    return int(found.edges[a]), int(found.edges[b])
