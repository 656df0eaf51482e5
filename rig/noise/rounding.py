"""The noise ahead of a coarse rounding, given where each pose sits on the grid: the twin's replicas are rounded at
the recording's own pose means, and below about a step the spread a pose shows depends on that place
(`rig.calibration.numerics.quantisation` has the mean over all places, which a calibration needs without scipy's
optimiser at start-up)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr


def rounded_variance(mu: np.ndarray, sigma: float, q: float) -> np.ndarray:
    """Variance of round(x / q) q for x ~ N(mu, sigma^2), at each mu: the levels' probabilities from the normal CDF."""
    mu = np.atleast_1d(np.asarray(mu, dtype=float))
    if sigma <= 0:
        return np.zeros_like(mu)
    reach = int(np.ceil(8.0 * sigma / q)) + 1
    levels = np.round(mu / q)[:, None] + np.arange(-reach, reach + 1)[None, :]
    p = ndtr(((levels + 0.5) * q - mu[:, None]) / sigma) - ndtr(((levels - 0.5) * q - mu[:, None]) / sigma)
    value = levels * q
    mean = np.sum(p * value, axis=1)
    return np.maximum(np.sum(p * value ** 2, axis=1) - mean ** 2, 0.0)


def noise_sigma_at(means: np.ndarray, variances: np.ndarray, weights: np.ndarray, q: float) -> float | None:
    """The Gaussian sigma ahead of a rounding to steps of q that gives poses at `means` their observed `variances`
    on average (`weights`), or None where none does. Below about half a step the variance of one pose depends on
    where its value sits between two levels (a value on a level hardly moves; one halfway flips between two), which
    the mean over all places (`quantisation.noise_sigma`) does not know; the pose's mean says where it sits. From a
    step on, the two agree (the sawtooth's first harmonic is exp(-2 pi^2) of its size there)."""
    means, variances, weights = (np.asarray(a, dtype=float) for a in (means, variances, weights))
    target = float(np.sum(weights * variances) / np.sum(weights))

    def excess(sigma: float) -> float:
        return float(np.sum(weights * rounded_variance(means, sigma, q)) / np.sum(weights)) - target

    lo, hi = 1e-3 * q, max(2.0 * q, 2.0 * np.sqrt(target))
    if not target > 0 or excess(lo) > 0 or excess(hi) < 0:
        return None
    return float(brentq(excess, lo, hi, xtol=1e-9 * max(q, np.sqrt(target))))
