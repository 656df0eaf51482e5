"""rig.calibration.brent against scipy's minimize_scalar(method="bounded"), the reference it ports."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from rig.calibration.brent import minimize_bounded


def _functions(rng: np.random.Generator):
    for _ in range(60):
        c, w, k = rng.uniform(-3, 3), rng.uniform(0.1, 5), rng.integers(1, 5)
        f = lambda x, c=c, w=w, k=k: float(w * abs(x - c) ** (2 * k) + 0.1 * np.sin(7 * x))  # noqa: E731
        yield f, c - 4, c + rng.uniform(1, 6)
    yield (lambda x: float(np.cos(x))), 0.0, 20.0                   # many minima
    yield (lambda x: float(x)), -1.0, 1.0                            # minimum at the bound
    yield (lambda x: float(abs(x - 0.3))), 0.0, 1.0                  # kink
    yield (lambda x: 1.0), 0.0, 1.0                                  # flat
    yield (lambda x: float(1e-9 * (x - 3.7) ** 2)), 3.0, 4.0          # shallow


@pytest.mark.parametrize("xatol", [1e-5, 1e-8, 1e-3])
def test_same_iterates_as_scipy(xatol):
    for f, a, b in _functions(np.random.default_rng(11)):
        calls_ours, calls_ref = [], []
        x, fx, n = minimize_bounded(lambda s: calls_ours.append(s) or f(s), a, b, xatol=xatol)
        ref = minimize_scalar(lambda s: calls_ref.append(s) or f(s), bounds=(a, b), method="bounded",
                              options={"xatol": xatol})
        assert calls_ours == calls_ref
        assert (x, fx, n) == (float(ref.x), float(ref.fun), ref.nfev)


def test_bounds_are_checked():
    with pytest.raises(ValueError):
        minimize_bounded(lambda s: s, 1.0, 0.0)
    with pytest.raises(ValueError):
        minimize_bounded(lambda s: s, 0.0, np.inf)
