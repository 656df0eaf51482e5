"""The rounding-bias series cut where its terms cannot change the sum gives the full 64-harmonic sum to rounding; the
noise ahead of a coarse rounding is found from where the poses sit on the grid."""

import numpy as np

from rig.calibration.numerics import quantisation as Q
from rig.noise.rounding import noise_sigma_at

EPS = np.finfo(float).eps


def _full(sigma: np.ndarray) -> np.ndarray:
    k2 = np.arange(1, 65)[:, None] ** 2
    return np.sqrt(np.sum(np.exp(-4 * np.pi ** 2 * k2 * sigma.ravel() ** 2) / (2 * np.pi ** 2 * k2), axis=0)
                   ).reshape(sigma.shape)


def test_cut_series_equals_the_full_one_to_rounding():
    rng = np.random.default_rng(61)
    for sigma in [np.array([0.0]), rng.uniform(0, 0.05, 50), rng.uniform(0, 3, (30, 3)),
                  10.0 ** rng.uniform(-9, 1, 200), Q._SIGMA_GRID]:
        # the terms left out are below 1e-20 of the sum: what remains is the last bits of two sums of exponentials
        np.testing.assert_allclose(Q.rounding_bias_rms(sigma), _full(sigma), rtol=8 * EPS, atol=0)
    grid = Q._SIGMA_GRID
    np.testing.assert_allclose(Q._WITHIN_VARIANCE, grid ** 2 + Q.QUANTISATION_STD ** 2 - _full(grid) ** 2,
                               rtol=0, atol=8 * EPS * (grid[-1] ** 2 + 1))


def test_the_noise_ahead_of_a_coarse_rounding_is_found_from_where_the_poses_sit():
    """Poses rounded to steps of 8 under sigma 3 (less than half a step): one pose's spread depends on where its value
    sits between two levels (at a level 3.4, halfway 4.1), so the mean over all places misjudges it; given each
    pose's mean the sigma comes back, alone or pooled, and with plenty of noise it is the Sheppard-corrected spread."""
    rng = np.random.default_rng(7)
    q, sigma = 8.0, 3.0
    means, variances = [], []
    for centre in (0.0, 2.0, 4.0, 5.5):
        x = np.round((centre + rng.normal(0.0, sigma, 100_000)) / q) * q
        means.append(x.mean())
        variances.append(x.var())
        assert abs(noise_sigma_at([x.mean()], [x.var()], [1.0], q) - sigma) < 0.05 * sigma
    assert np.ptp(np.sqrt(variances)) > 0.5                    # the places do differ
    pooled = noise_sigma_at(means, variances, np.ones(4), q)
    assert abs(pooled - sigma) < 0.03 * sigma
    assert abs(noise_sigma_at([0.3], [40.0 ** 2 + q ** 2 / 12], [1.0], q) - 40.0) < 1e-6
    assert noise_sigma_at([0.0], [0.0], [1.0], q) is None       # a pose that never moves says nothing
    halfway = Q.noise_sigma(np.full((1, 3), np.sqrt(variances[2]) / q))[0] * q     # the mean over places
    assert abs(halfway - sigma) > 0.1 * sigma
