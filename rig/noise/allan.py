"""Allan deviation of a static stream and the noise terms it shows (IEEE Std 952, Annex C; El-Sheimy et al. 2008).

The overlapping estimator is allantools' (`oadev`, octave-spaced averaging times from one sample to a third of
the stretch, where it still averages three independent clusters); its own error estimate weighs the fit. The
Allan variance of independent noise terms adds (IEEE 952, C.1):

    AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3

with Q quantisation, N white noise (angle/velocity random walk, unit per sqrt(Hz)), B bias instability (flicker
floor) and K rate random walk; the coefficients are fitted by non-negative weighted least squares (Lv et al.,
Optik 2015, recommend weighting by the estimator's variance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

FLICKER = 2 * math.log(2) / math.pi


@dataclass
class AllanCurve:
    tau: np.ndarray       # s
    adev: np.ndarray      # unit of the stream
    err: np.ndarray       # 1-sigma of adev, from the estimator's equivalent degrees of freedom
    n: np.ndarray         # terms averaged


@dataclass
class NoiseTerms:
    """Coefficients of the four terms (0 where the fit does not need the term) and their standard deviations."""

    Q: float
    N: float
    B: float
    K: float
    std: dict

    def adev(self, tau: np.ndarray) -> np.ndarray:
        tau = np.asarray(tau, dtype=float)
        return np.sqrt(3 * self.Q ** 2 / tau ** 2 + self.N ** 2 / tau + FLICKER * self.B ** 2 + self.K ** 2 * tau / 3)


def allan_deviation(x: np.ndarray, rate_hz: float, *, longest_fraction: float = 1 / 3) -> AllanCurve:
    """Overlapping Allan deviation of a uniformly sampled stream x (n,) at octave taus up to a third of it."""
    import allantools

    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if len(x) < 8:
        raise ValueError(f"Allan deviation: {len(x)} samples; at least 8 are needed")
    if np.ptp(x) == 0:
        # A stuck axis (or a column that never changes) has no noise to fit: its curve is zero at every tau (and
        # empty once those are dropped), or rounding leaves a few 1e-20 that read as a unit that is not still.
        raise ValueError(f"the same value {x[0]:g} on all {len(x)} samples (a stuck axis): no noise to analyse")
    tau, adev, _, n = allantools.oadev(x, rate=float(rate_hz), data_type="freq", taus="octave")
    keep = (tau <= longest_fraction * len(x) / rate_hz + 1e-12) & (adev > 0)
    tau, adev, n = tau[keep], adev[keep], n[keep]
    if not len(tau):
        raise ValueError(f"an Allan deviation of zero at every tau up to a third of its {len(x)} samples: no noise "
                         "to analyse")
    # allantools' error, adev / sqrt(pairs), counts the overlapping pairs as independent: at a third of the
    # stream it is a hundred times too small, and a fit weighted by it heard only the shortest taus (a white
    # gyro "showed" a rate random walk). The chi-square's equivalent degrees of freedom of the overlapping
    # estimator (Howe et al. 1981; allantools.edf_simple) give var(AVAR) = 2 AVAR^2 / edf; the fewer of white
    # and random-walk frequency noise's, since which of them rules the longest taus is what the fit is to find.
    edf = np.array([min(allantools.edf_simple(len(x), int(round(t * rate_hz)), alpha) for alpha in (0, -2))
                    for t in tau])
    return AllanCurve(tau, adev, adev / np.sqrt(2 * edf), n)


def fit_noise(curve: AllanCurve) -> NoiseTerms:
    """The non-negative Q, N, B, K whose AVAR matches the curve, weighted by the estimator's variance."""
    tau = curve.tau
    A = np.column_stack([3 / tau ** 2, 1 / tau, np.full_like(tau, FLICKER), tau / 3])
    sd_avar = np.maximum(2 * curve.adev * curve.err, 1e-300)
    w = 1.0 / sd_avar
    coef, _ = nnls(A * w[:, None], curve.adev ** 2 * w)
    active = coef > 0
    cov = np.zeros((4, 4))
    if active.any():
        Aw = (A * w[:, None])[:, active]
        cov_a = np.linalg.pinv(Aw.T @ Aw)
        cov[np.ix_(active, active)] = cov_a
    q, n, b, k = np.sqrt(coef)
    # d sqrt(c) = dc / (2 sqrt(c)): the standard deviation of each coefficient from its squared term's
    sd = [math.sqrt(cov[i, i]) / (2 * v) if v > 0 else math.sqrt(math.sqrt(max(cov[i, i], 0.0)))
          for i, v in enumerate((q, n, b, k))]
    return NoiseTerms(float(q), float(n), float(b), float(k), {"Q": sd[0], "N": sd[1], "B": sd[2], "K": sd[3]})
