"""The rounding-bias series cut where its terms cannot change the sum gives the full 64-harmonic sum exactly."""

import numpy as np

from rig.calibration import quantisation as Q


def _full(sigma: np.ndarray) -> np.ndarray:
    k2 = np.arange(1, 65)[:, None] ** 2
    return np.sqrt(np.sum(np.exp(-4 * np.pi ** 2 * k2 * sigma.ravel() ** 2) / (2 * np.pi ** 2 * k2), axis=0)
                   ).reshape(sigma.shape)


def test_cut_series_equals_the_full_one_to_the_bit():
    rng = np.random.default_rng(61)
    for sigma in [np.array([0.0]), rng.uniform(0, 0.05, 50), rng.uniform(0, 3, (30, 3)),
                  10.0 ** rng.uniform(-9, 1, 200), Q._SIGMA_GRID]:
        assert np.array_equal(Q.rounding_bias_rms(sigma), _full(sigma))
    grid = Q._SIGMA_GRID
    assert np.array_equal(Q._WITHIN_VARIANCE, grid ** 2 + Q.QUANTISATION_STD ** 2 - _full(grid) ** 2)
