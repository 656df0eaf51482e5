"""The reference angles between encoder polls: a cubic Hermite through positions and rates, held at the ends."""

import numpy as np

from procedures.reference import interpolate_angles


def test_the_reference_follows_positions_and_rates_not_a_straight_line():
    """A move sampled by 10 Hz polls of position and rate: between polls the reference stays within a few
    thousandths of a degree of the true angle, where a straight line between polls misses by a tenth or more."""
    def angle(t):
        return np.column_stack([40 * np.sin(2 * t) + 10 * t, -30 * np.cos(1.5 * t)])

    def rate(t):
        return np.column_stack([80 * np.cos(2 * t) + 10, 45 * np.sin(1.5 * t)])

    pt = np.arange(0.0, 3.0, 0.1)
    t = np.linspace(pt[0], pt[-1], 500)
    got = interpolate_angles(t, pt, angle(pt), rate(pt))
    assert np.abs(got - angle(t)).max() < 0.01
    straight = np.column_stack([np.interp(t, pt, angle(pt)[:, i]) for i in range(2)])
    assert np.abs(straight - angle(t)).max() > 0.1
    ends = interpolate_angles(np.array([-1.0, 5.0]), pt, angle(pt), rate(pt))
    np.testing.assert_allclose(ends, angle(pt[[0, -1]]), rtol=0, atol=1e-9)


def test_repeated_poll_times_and_a_single_poll():
    pt, pos, vel = [0.0, 0.0, 1.0], [[0, 0], [0, 0], [10, 20]], [[0, 0], [0, 0], [0, 0]]
    got = interpolate_angles(np.array([0.0, 0.5, 1.0]), pt, pos, vel)
    np.testing.assert_allclose(got, [[0, 0], [5, 10], [10, 20]])
    np.testing.assert_allclose(interpolate_angles(np.zeros(3), [1.0], [[3, 4]], [[0, 0]]), [[3, 4]] * 3)
