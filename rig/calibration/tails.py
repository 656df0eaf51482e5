"""Upper tail probabilities of the chi-square and F distributions, for the significance tests.

`chi2_sf(x, k) = Q(k/2, x/2)` (regularised upper incomplete gamma) and `f_sf(x, d1, d2) = I_z(d2/2, d1/2)`
with `z = d2 / (d2 + d1 x)` (regularised incomplete beta; Abramowitz & Stegun 26.4.2, 26.6.2), by the series
and continued fractions of Press et al., Numerical Recipes, 3rd ed., 6.2 and 6.4 (modified Lentz).
scipy.stats is the reference (tests/startup/test_tails.py holds both equal to ~1e-12): importing it, or
scipy.special, costs more than a whole `rig calibrate --from` may take (issue 17, start-up).
"""

from __future__ import annotations

import math

_EPS = 1e-16
_TINY = 1e-300
_MAX_TERMS = 10000


def chi2_sf(x: float, k: float) -> float:
    """P(X > x) for X ~ chi^2 with k degrees of freedom."""
    if not k > 0:
        raise ValueError(f"chi2_sf: degrees of freedom must be positive, got {k!r}")
    if math.isnan(x):
        return math.nan
    if x <= 0:
        return 1.0
    if math.isinf(x):
        return 0.0
    return _gamma_q(0.5 * k, 0.5 * x)


def f_sf(x: float, d1: float, d2: float) -> float:
    """P(X > x) for X ~ F(d1, d2)."""
    if not (d1 > 0 and d2 > 0):
        raise ValueError(f"f_sf: degrees of freedom must be positive, got {d1!r}, {d2!r}")
    if math.isnan(x):
        return math.nan
    if x <= 0:
        return 1.0
    if math.isinf(x):
        return 0.0
    r = d1 * x / d2
    return _beta_i(1.0 / (1.0 + r), r / (1.0 + r), -math.log1p(r), math.log(r) - math.log1p(r), 0.5 * d2, 0.5 * d1)


def f_isf(p: float, d1: float, d2: float) -> float:
    """The x with P(X > x) = p for X ~ F(d1, d2), by bisection of `f_sf` in log x (monotone; to 1e-13 of x). The
    square of Student's t quantile: t_{nu, 1 - q/2}^2 = f_isf(q, 1, nu)."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"f_isf: p must be in (0, 1), got {p!r}")
    lo, hi = -60.0, 60.0                                  # log x: f_sf runs from 1 to 0 across any d1, d2 used here
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f_sf(math.exp(mid), d1, d2) > p else (lo, mid)
        if hi - lo < 1e-13:
            break
    return math.exp(0.5 * (lo + hi))


def _gamma_q(a: float, x: float) -> float:
    """Q(a, x) = Gamma(a, x) / Gamma(a): the series of P below a + 1, the continued fraction above."""
    log_front = a * math.log(x) - x - math.lgamma(a)
    if x < a + 1.0:
        term = total = 1.0 / a
        ap = a
        for _ in range(_MAX_TERMS):
            ap += 1.0
            term *= x / ap
            total += term
            if abs(term) < abs(total) * _EPS:
                break
        return 1.0 - total * math.exp(log_front)
    b = x + 1.0 - a
    c, d = 1.0 / _TINY, 1.0 / b
    h = d
    for i in range(1, _MAX_TERMS):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = _TINY if abs(d) < _TINY else d
        c = b + an / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    return math.exp(log_front) * h


def _beta_i(z: float, zc: float, log_z: float, log_zc: float, a: float, b: float) -> float:
    """I_z(a, b) given z, zc = 1 - z and their logarithms (each computed without cancellation), from the
    continued fraction on the side of z where it converges fast."""
    if z <= 0.0:
        return 0.0
    if zc <= 0.0:
        return 1.0
    log_front = -_log_beta(a, b) + a * log_z + b * log_zc
    if z < (a + 1.0) / (a + b + 2.0):
        return math.exp(log_front) * _beta_cf(z, a, b) / a
    return 1.0 - math.exp(log_front) * _beta_cf(zc, b, a) / b


def _log_beta(a: float, b: float) -> float:
    """log B(a, b); for a large parameter by Stirling's series, since the difference of two large lgamma
    values would lose ~|lgamma| x 1e-16 (1e-12 at 5000 degrees of freedom)."""
    small, large = min(a, b), max(a, b)
    if large < 10.0:
        return math.lgamma(a) + math.lgamma(b) - math.lgamma(a + b)
    ratio = ((large - 0.5) * math.log1p(small / large) + small * math.log(large + small) - small
             + _stirling_tail(large + small) - _stirling_tail(large))        # lgamma(a + b) - lgamma(large)
    return math.lgamma(small) - ratio


def _stirling_tail(x: float) -> float:
    """lgamma(x) - ((x - 1/2) log x - x + log(2 pi)/2), x >= 10 (A&S 6.1.41; next term < 2e-14)."""
    inv, inv2 = 1.0 / x, 1.0 / (x * x)
    return inv * (1.0 / 12.0 - inv2 * (1.0 / 360.0 - inv2 * (1.0 / 1260.0 - inv2 / 1680.0)))


def _beta_cf(z: float, a: float, b: float) -> float:
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * z / qap
    d = 1.0 / (_TINY if abs(d) < _TINY else d)
    h = d
    for m in range(1, _MAX_TERMS):
        m2 = 2 * m
        for aa in (m * (b - m) * z / ((qam + m2) * (a + m2)), -(a + m) * (qab + m) * z / ((a + m2) * (qap + m2))):
            d = 1.0 + aa * d
            d = 1.0 / (_TINY if abs(d) < _TINY else d)
            c = 1.0 + aa / c
            c = _TINY if abs(c) < _TINY else c
            h *= d * c
        if abs(d * c - 1.0) < _EPS:
            break
    return h
