"""Samples pinned at a rail: where a sensor saturated (clipped at its range) in a recording.

A clipped output piles its samples up at the stream's extreme value: every sample beyond the range reads the
rail itself, so the largest (smallest) value is held by several samples, far more than any of the values just
below (above) it. An unclipped stream thins out towards its extremes, in float SI data (where values hardly
repeat) as in integer counts (where every value near the middle repeats): noise and motion reach the extreme
once or a few times, fewer than the values next to it. A gyro at rest never reaches its extremes; the motions
do. Nothing here knows the sensor's range: a user's logger may clip at any value (250 deg/s written at 65.5
counts per deg/s is 16375, not a power of two), so the pile is the evidence, not the code
(`rig.pipeline.screening.is_rail` knows the ADC codes of the rig's own chips).

The calibration from a recording leaves out what touched a rail (`rig.calibration.recordings.recording`,
`rig.calibration.recordings.turntable_free`); the discrepancy's `pinned` statistic counts the same piles
(`rig.noise.statistics`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_PILE = 3          # samples at the extreme before it is a pile ("several"; a clip of a few samples counts)
PILE_FACTOR = 4       # ... and this many times more than the most held of the values just inside it
NEIGHBOURS = 3        # the values just inside the extreme it is compared with
MIN_LEVELS = 2 * NEIGHBOURS + 2   # fewer distinct values (a quiet stream of a few codes): no shape to judge by


@dataclass(frozen=True)
class Rail:
    """An extreme of one axis of a stream at which samples pile up."""

    axis: int
    value: float
    count: int                # samples of the whole stream at it


def distinct(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The finite values of x, sorted and distinct, and how often each occurs (np.unique's answer; counted without
    a sort where the values are whole numbers of a modest range, as a recording in counts has, ten times faster)."""
    x = x[np.isfinite(x)]
    if x.size:
        lo, hi = float(x.min()), float(x.max())
        if hi - lo <= max(4 * x.size, 1024) and abs(lo) < 2 ** 52 and abs(hi) < 2 ** 52 and np.all(x == np.floor(x)):
            counts = np.bincount((x - lo).astype(np.int64))
            present = np.flatnonzero(counts)
            return present + lo, counts[present]
    return np.unique(x, return_counts=True)


def pinned_ends(values: np.ndarray, counts: np.ndarray) -> tuple[bool, bool]:
    """Whether the smallest and the largest of a stream's distinct values (sorted, with their counts) are piled
    up as clipping piles them: held by MIN_PILE samples or more, and by PILE_FACTOR times more than any of the
    NEIGHBOURS values next to it. The most held neighbour, not the next value alone, so that the thin tail of an
    unclipped stream in counts (an extreme held 3 times, the value inside it twice, the next 20 times) is not
    taken for a pile."""
    if len(values) < MIN_LEVELS:
        return False, False
    low = counts[0] >= MIN_PILE and counts[0] > PILE_FACTOR * counts[1:1 + NEIGHBOURS].max()
    high = counts[-1] >= MIN_PILE and counts[-1] > PILE_FACTOR * counts[-1 - NEIGHBOURS:-1].max()
    return bool(low), bool(high)


def rails(y: np.ndarray) -> list[Rail]:
    """The piled-up extremes of every axis of a stream y (n, 3) (NaN ignored), lowest axis first, and the ends of
    the same two's-complement range wherever an axis reaches them (`same_range`)."""
    out = []
    for k in range(y.shape[1]):
        values, counts = distinct(y[:, k])
        for end, pinned in zip((0, -1), pinned_ends(values, counts)):
            if pinned:
                out.append(Rail(k, float(values[end]), int(counts[end])))
    return same_range(y, out)


def same_range(y: np.ndarray, found: list[Rail]) -> list[Rail]:
    """A pile at -2^n or 2^n - 1 says the stream is a two's-complement code of n + 1 bits, clipped there: its other
    end, and both ends on every axis (a chip's axes share their range), are rails too wherever the stream reaches
    them, however few samples do. An MPU-6050 recording's gyro x piled 10 samples at -32768 and touched 32767
    twice, in a motion that was fitted as if whole."""
    codes = {v for r in found for v in _range_ends(r.value)}
    if not codes:
        return found
    out = list(found)
    for k in range(y.shape[1]):
        column = y[:, k][np.isfinite(y[:, k])]
        if not column.size:
            continue
        for value in (float(column.min()), float(column.max())):
            if value in codes and not any(r.axis == k and r.value == value for r in out):
                out.append(Rail(k, value, int(np.count_nonzero(column == value))))
    return sorted(out, key=lambda r: (r.axis, r.value))


def _range_ends(value: float) -> tuple[float, ...]:
    """(-2^n, 2^n - 1) where `value` is one of them (n from 7 to 31), else ()."""
    for n in range(7, 32):
        if value in (-2.0 ** n, 2.0 ** n - 1):
            return (-2.0 ** n, 2.0 ** n - 1)
    return ()


def pinned_rows(y: np.ndarray) -> tuple[list[Rail], np.ndarray]:
    """The rails of a stream y (n, 3) and (n,) True where a row reads one: the sample may have been beyond the
    range."""
    found = rails(y)
    hit = np.zeros(len(y), dtype=bool)
    for r in found:
        hit |= y[:, r.axis] == r.value
    return found, hit


def rail_names(sensor: str, found: list[Rail], columns: str | list[str] | None = None) -> str:
    """'gyro.x at 16375 (3 samples), gyro.y at -16375 (...)': the rails as a warning names them, with the user's
    column where the recording was imported."""
    def one(r: Rail) -> str:
        column = f" (column '{columns[r.axis]}')" if columns and len(columns) == 3 and columns != "xyz" else ""
        return f"{sensor}.{'xyz'[r.axis]}{column} pinned at {r.value:g} ({r.count} samples)"

    return ", ".join(one(r) for r in found)
