"""rig.calibration.tails against scipy.stats, the reference it replaces on the start-up path."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from rig.calibration.tails import chi2_sf, f_isf, f_sf


def _close(ours: float, ref: float, rtol: float = 1e-12) -> bool:
    return ours == ref or abs(ours - ref) <= rtol * abs(ref) + 1e-300


def test_chi2_tail_equals_scipys():
    rng = np.random.default_rng(21)
    xs = np.concatenate([10.0 ** rng.uniform(-8, 2.8, 400), [1e-300, 0.5, 1.0, 3.0, 7.8, 50.0, 600.0]])
    for k in (1, 2, 3, 4, 5, 7.5, 10, 30, 100):
        for x in xs:
            assert _close(chi2_sf(x, k), stats.chi2.sf(x, k)), (x, k, chi2_sf(x, k), stats.chi2.sf(x, k))


def test_f_tail_equals_scipys():
    rng = np.random.default_rng(22)
    xs = np.concatenate([10.0 ** rng.uniform(-8, 4, 200), [1e-300, 0.5, 1.0, 3.0, 7.8, 50.0, 1e6]])
    for d1 in (1, 2, 3, 5):
        for d2 in (1, 2, 3, 4, 7, 19, 20, 60, 500, 5000):
            for x in xs:
                ref = stats.f.sf(x, d1, d2)
                assert _close(f_sf(x, d1, d2), ref, 1e-11), (x, d1, d2, f_sf(x, d1, d2), ref)


def test_f_quantile_equals_scipys_and_gives_students_t_squared():
    for p in (1e-6, 0.01, 0.3173105078629141, 0.5, 0.9):
        for d1, d2 in ((1, 1), (1, 3), (1, 29), (2, 7), (5, 500)):
            assert _close(f_isf(p, d1, d2), stats.f.isf(p, d1, d2), 1e-10), (p, d1, d2)
    assert _close(f_isf(0.3173105078629141, 1, 3), stats.t.ppf(0.8413447460685429, 3) ** 2, 1e-10)


def test_edges():
    assert chi2_sf(0.0, 3) == 1.0 and chi2_sf(-1.0, 3) == 1.0 and chi2_sf(math.inf, 3) == 0.0
    assert f_sf(0.0, 3, 19) == 1.0 and f_sf(math.inf, 3, 19) == 0.0
    assert math.isnan(chi2_sf(math.nan, 3)) and math.isnan(f_sf(math.nan, 3, 19))
    with pytest.raises(ValueError):
        f_sf(1.0, 3, 0)
    with pytest.raises(ValueError):
        chi2_sf(1.0, 0)
