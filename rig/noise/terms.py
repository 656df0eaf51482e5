"""Which of the IEEE 952 noise terms a record determines, and their sizes (IEEE Std 952-1997, Annex C; El-Sheimy,
Hou and Niu, IEEE TIM 57(1), 2008).

Each term rules the Allan variance over its own range of cluster times tau: quantisation (slope -1 in the Allan
deviation) and white noise (-1/2) at the shortest, bias instability (the flat floor) and rate random walk (+1/2)
at the longest. A record of T seconds holds about T / tau independent clusters at tau, and the Allan deviation
there is known to a fraction 1 / sqrt(2 (T / tau - 1)) (IEEE 952 C.1, El-Sheimy et al. sec. III); a term is
determinable only where it rules the curve at a tau the record holds at least `MIN_CLUSTERS` clusters of, and the
fit weighted by the estimator's own confidence (`rig.noise.allan`) finds it at least `MIN_Z` standard deviations
from nothing. The octave taus' Allan variances are close to independent (Schlossberger and Howe, IFCS 2019), which
the significance counts on.

Every term ends in one of three states: `fitted` (its value and deviation), `not determinable` (the record is too
short for its tau: the term may be there, below a bound the record does give), or `absent` (a short-tau term the
record would have shown, below that bound).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from rig.noise.allan import FLICKER, AllanCurve

MIN_CLUSTERS = 9          # independent clusters at a tau: its Allan deviation known to 1 / sqrt(16), 25 %
MIN_Z = 3.0               # a term's squared coefficient this many standard deviations from zero
REWEIGHTS = 3             # fits weighted by the model's own Allan variance (iteratively reweighted least squares)
TERM_KEYS = ("Q", "N", "B", "K")
SHORT_TAU_TERMS = ("Q", "N")        # read at the shortest taus, which every record holds many clusters of
FITTED, NOT_DETERMINABLE, ABSENT = "fitted", "not determinable", "absent"


def design(tau: np.ndarray) -> np.ndarray:
    """The Allan variance of each term at unit coefficient (IEEE 952 C.1): 3 / tau^2, 1 / tau, 2 ln 2 / pi, tau / 3."""
    tau = np.asarray(tau, dtype=float)
    return np.column_stack([3 / tau ** 2, 1 / tau, np.full_like(tau, FLICKER), tau / 3])


@dataclass
class Term:
    key: str
    status: str
    value: float | None            # the coefficient where fitted
    std: float | None
    bound: float                   # the largest coefficient the supported taus leave room for
    ruling_tau_s: tuple[float, float] | None     # where it rules the fitted curve, if it does anywhere

    def to_dict(self) -> dict:
        return {"status": self.status, "value": self.value, "std": self.std, "bound": self.bound,
                "ruling_tau_s": list(self.ruling_tau_s) if self.ruling_tau_s else None}


@dataclass
class TermFit:
    record_s: float
    terms: dict[str, Term]
    coefficients: np.ndarray       # the squared coefficients of the fit kept (0 for a term dropped)


def clusters(tau: np.ndarray, record_s: float) -> np.ndarray:
    """Independent clusters of the record at each tau."""
    return record_s / np.asarray(tau, dtype=float)


def _weighted_fit(A: np.ndarray, y: np.ndarray, w: np.ndarray, allowed: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Non-negative least squares of y on the allowed columns of A, rows weighted by w; the coefficients (4,) and
    their covariance (4, 4) over the terms the fit keeps."""
    coef = np.zeros(4)
    cov = np.zeros((4, 4))
    if not allowed:
        return coef, cov
    Aw = A[:, allowed] * w[:, None]
    sub, _ = nnls(Aw, y * w)
    coef[allowed] = sub
    active = [k for k, c in zip(allowed, sub) if c > 0]
    if active:
        Aa = A[:, active] * w[:, None]
        cov[np.ix_(active, active)] = np.linalg.pinv(Aa.T @ Aa)
    return coef, cov


def _reweighted_fit(A: np.ndarray, avar: np.ndarray, relative: np.ndarray,
                    allowed: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The fit weighted by each point's standard deviation, taken from the model's Allan variance once there is
    one: weights from the measured values favour the points that came out low, and bias every term down. The
    covariance is widened by the fit's reduced chi-square where that exceeds one (the octave taus' estimates are
    not quite independent, and the model not quite the noise)."""
    w = 1.0 / np.maximum(relative * avar, 1e-300)
    for _ in range(REWEIGHTS):
        coef, cov = _weighted_fit(A, avar, w, allowed)
        model = A @ coef
        if not (model > 0).all():
            break
        w = 1.0 / (relative * model)
    coef, cov = _weighted_fit(A, avar, w, allowed)
    kept = int((coef > 0).sum())
    if len(avar) > kept:
        chi2 = float(np.sum(((avar - A @ coef) * w) ** 2)) / (len(avar) - kept)
        cov = cov * max(chi2, 1.0)
    return coef, cov


def determine_terms(curve: AllanCurve, record_s: float) -> TermFit:
    """The terms of the curve of a record of `record_s` seconds, each fitted, not determinable or absent (module
    docstring). Terms are dropped from the fit, least significant first, until every one kept is significant; a
    significant term that rules no tau with `MIN_CLUSTERS` clusters stays in the fit (so that the others are not
    made to carry it) but is not named: a bias instability or rate random walk is then not determinable, and a
    quantisation or white noise, read at the shortest taus every record holds, absent (a model that bends
    elsewhere, a Gauss-Markov bias's hump, leans on it without the curve showing its slope)."""
    tau, avar = curve.tau, curve.adev ** 2
    A = design(tau)
    relative = 2 * curve.err / np.maximum(curve.adev, 1e-300)           # sd(AVAR) / AVAR, from the estimator's edf
    allowed = [0, 1, 2, 3]
    while True:
        coef, cov = _reweighted_fit(A, avar, relative, allowed)
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        z = np.where(sd > 0, coef / np.where(sd > 0, sd, 1.0), np.where(coef > 0, np.inf, 0.0))
        weak = [k for k in allowed if z[k] < MIN_Z]
        if not weak:
            break
        allowed.remove(min(weak, key=lambda k: z[k]))
    parts = A * coef[None, :]
    total = parts.sum(axis=1)
    supported = clusters(tau, record_s) >= MIN_CLUSTERS
    upper = curve.adev + 2 * curve.err
    terms = {}
    for k, key in enumerate(TERM_KEYS):
        room = np.sqrt(upper[supported] ** 2 / A[supported, k]) if supported.any() else np.sqrt(upper ** 2 / A[:, k])
        bound = float(room.min())
        rules = (parts[:, k] >= 0.5 * total) & (coef[k] > 0)
        ruling = (float(tau[rules].min()), float(tau[rules].max())) if rules.any() else None
        if coef[k] > 0 and (rules & supported).any():
            value = math.sqrt(coef[k])
            terms[key] = Term(key, FITTED, value, float(sd[k] / (2 * value)), bound, ruling)
        elif key in SHORT_TAU_TERMS:
            terms[key] = Term(key, ABSENT, None, None, bound, None)
        else:
            terms[key] = Term(key, NOT_DETERMINABLE, None, None, bound, ruling)
    return TermFit(float(record_s), terms, coef)
