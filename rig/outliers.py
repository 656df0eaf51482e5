"""Isolated outlier samples of a still signal (a bus glitch that reads 2^31, a flipped bit), set aside with a
count, so one bad sample costs one sample and not the whole hold (or two moves with it).

A sample is an outlier when it lies further from the hold's median than OUTLIER_SIGMAS robust standard
deviations (1.4826 MAD, floored at OUTLIER_FLOOR counts for quantised sensors that show no noise) on any axis:
Gaussian noise never gets there (P < 1e-22 per sample at 10 sigma). Only a few such samples are set aside
(at most MAX_OUTLIER_FRACTION of the hold, and never fewer than MIN_OUTLIERS allowed): many of them are not
glitches but motion (a knock rings over tens of samples), and are left in place for the motion checks.
"""

from __future__ import annotations

import numpy as np

OUTLIER_SIGMAS = 10.0
OUTLIER_FLOOR = 1.0
MAX_OUTLIER_FRACTION = 0.01
MIN_OUTLIERS = 2
MIN_SAMPLES = 8


def isolated_outliers(y: np.ndarray) -> np.ndarray:
    """Rows of `y` (n, 3; no NaN) that are isolated outliers of a still signal, as a boolean mask."""
    y = np.asarray(y, dtype=float)
    none = np.zeros(len(y), dtype=bool)
    if len(y) < MIN_SAMPLES:
        return none
    centre = np.median(y, axis=0)
    deviation = np.abs(y - centre)
    sigma = 1.4826 * np.median(deviation, axis=0)
    with np.errstate(invalid="ignore"):
        out = (deviation > OUTLIER_SIGMAS * np.maximum(sigma, OUTLIER_FLOOR)).any(axis=1)
    k = int(out.sum())
    if k == 0 or k > max(MIN_OUTLIERS, MAX_OUTLIER_FRACTION * len(y)):
        return none
    return out
