"""How well the mean of integer counts knows the value behind them.

With noise of a count or more the rounding errors of the samples are independent and average away like the
noise (variance 1/12 count^2 each). Without it they do not: a still, noiseless reading rounds to the same count
every time and its mean is up to half a count off however long the hold. In between, the mean of samples with
Gaussian noise sigma keeps a deterministic rounding bias, a sawtooth in the true value whose k-th harmonic has
amplitude exp(-2 pi^2 k^2 sigma^2) / (pi k) (Widrow and Kollar, *Quantization Noise*, 2008, ch. 4-6); over
true values spread across a count its mean square is the sum below, 1/12 at sigma = 0.
"""

from __future__ import annotations

import numpy as np

QUANTISATION_STD = 1 / np.sqrt(12.0)   # counts: the rounding error of one sample, uniform on +-0.5
_HARMONICS = np.arange(1, 65)[:, None]


def rounding_bias_rms(sigma: np.ndarray) -> np.ndarray:
    """RMS rounding bias (counts) of the mean of many samples with Gaussian noise `sigma` (counts).

    Harmonics below 1e-20 of the first for the smallest sigma are left out: they cannot change the sum."""
    sigma = np.atleast_1d(np.asarray(sigma, dtype=float))
    k2 = _HARMONICS[:_harmonics_needed(float(sigma.min()) if sigma.size else 0.0)] ** 2
    return np.sqrt(np.sum(np.exp(-4 * np.pi ** 2 * k2 * sigma.ravel() ** 2) / (2 * np.pi ** 2 * k2), axis=0)
                   ).reshape(sigma.shape)


def _harmonics_needed(sigma_min: float) -> int:
    """How many harmonics reach 1e-20 of the first: exp(-4 pi^2 sigma^2 (k^2 - 1)) < 1e-20."""
    if not sigma_min > 0:
        return len(_HARMONICS)
    return int(min(len(_HARMONICS), np.ceil(np.sqrt(1.0 + np.log(1e20) / (4 * np.pi ** 2 * sigma_min ** 2)))))


_SIGMA_GRID = np.linspace(0.0, 2.0, 4001)
# Mean within-hold variance of rounded samples with noise sigma, over true values spread across a count: the
# total variance sigma^2 + 1/12 less the part that the rounding bias moves from hold to hold. Increasing.
# Computed in pieces so that each needs only its own harmonics (a fifth of the import time, same values).
_WITHIN_VARIANCE = _SIGMA_GRID ** 2 + QUANTISATION_STD ** 2 - np.concatenate(
    [rounding_bias_rms(piece) for piece in np.array_split(_SIGMA_GRID, 16)]) ** 2


def noise_sigma(std: np.ndarray) -> np.ndarray:
    """Gaussian noise sigma (counts) per axis from the observed stds (k, 3) of k holds of rounded samples.

    Beyond the table (sigma > 2 counts) the rounding bias is nil and the rounding adds its 1/12 (Sheppard)."""
    variance = np.mean(np.square(std), axis=0)
    return np.where(variance <= _WITHIN_VARIANCE[-1], np.interp(variance, _WITHIN_VARIANCE, _SIGMA_GRID),
                    np.sqrt(np.maximum(variance - QUANTISATION_STD ** 2, 0.0)))


def mean_standard_error(std: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Standard error (counts) of hold means (k, 3) of `count` (k,) integer samples with observed std (k, 3).

    The noise part shrinks with the count and is floored at the rounding noise. The rounding bias does not
    shrink; it depends on the Gaussian noise sigma of the axis, which the holds share, so sigma comes from the
    mean observed variance of all holds (noise_sigma), not from one hold's std: near a count boundary a
    noiseless hold flips and looks noisy, near a count centre a noisy one looks still.
    """
    std = np.asarray(std, dtype=float)
    n = np.asarray(count, dtype=float)[:, None]
    noise = np.maximum(std, QUANTISATION_STD) ** 2 / n
    return np.sqrt(noise + rounding_bias_rms(noise_sigma(std)) ** 2)

