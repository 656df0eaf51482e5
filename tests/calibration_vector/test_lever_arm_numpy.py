"""The lever arm's smoothing and significance test in numpy, against scipy (ndimage, stats) as the reference."""

from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.ndimage import uniform_filter1d

from rig.calibration.lever_arm import _wald_p_value, moving_mean


def test_moving_mean_is_scipys_uniform_filter_with_nearest_ends():
    rng = np.random.default_rng(31)
    for shape in [(1,), (2, 3), (7, 3, 3), (500, 3), (1000, 3, 3)]:
        a = rng.normal(size=shape) * 10.0 ** rng.uniform(-3, 3)
        for width in (1, 3, 5, 9, 21):
            ref = uniform_filter1d(a, size=width, axis=0, mode="nearest")
            np.testing.assert_allclose(moving_mean(a, width), ref, rtol=1e-12, atol=1e-13 * np.abs(a).max())


def test_wald_p_value_is_scipys():
    rng = np.random.default_rng(32)
    for clusters in (1, 2, 5, 20, 64):
        for _ in range(20):
            r = rng.normal(size=3) * 1e-4
            A = rng.normal(size=(3, 3)) * 1e-4
            cov = A @ A.T + 1e-12 * np.eye(3)
            wald = float(r @ np.linalg.solve(cov, r))
            ref = stats.chi2.sf(wald, 3) if clusters < 2 else stats.f.sf(wald / 3.0, 3, clusters - 1)
            assert abs(_wald_p_value(r, cov, clusters) - ref) <= 1e-12 * ref + 1e-300
