"""The reference angles between encoder polls: our cubic Hermite equals scipy's CubicHermiteSpline."""

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from procedures.reference import interpolate_angles


def test_hermite_equals_scipy():
    rng = np.random.default_rng(3)
    pt = np.cumsum(rng.uniform(0.05, 0.2, 12))
    pos, vel = rng.normal(0, 40, (12, 2)), rng.normal(0, 60, (12, 2))
    t = np.linspace(pt[0] - 0.1, pt[-1] + 0.1, 500)
    got = interpolate_angles(t, pt, pos, vel)
    tc = np.clip(t, pt[0], pt[-1])
    want = np.column_stack([CubicHermiteSpline(pt, pos[:, i], vel[:, i])(tc) for i in range(2)])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
    assert not np.allclose(got, np.column_stack([np.interp(tc, pt, pos[:, i]) for i in range(2)]), atol=1e-3)


def test_repeated_poll_times_and_a_single_poll():
    pt, pos, vel = [0.0, 0.0, 1.0], [[0, 0], [0, 0], [10, 20]], [[0, 0], [0, 0], [0, 0]]
    got = interpolate_angles(np.array([0.0, 0.5, 1.0]), pt, pos, vel)
    np.testing.assert_allclose(got, [[0, 0], [5, 10], [10, 20]])
    np.testing.assert_allclose(interpolate_angles(np.zeros(3), [1.0], [[3, 4]], [[0, 0]]), [[3, 4]] * 3)
