"""Hold means of integer counts: the standard error the joint fit weighs them by, against simulation."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rig.calibration.turntable.joint import calibrate_joint
from rig.calibration.numerics.quantisation import mean_standard_error


@pytest.mark.parametrize("sigma", [0.0, 0.1, 0.2, 0.3, 0.45, 1.0])
def test_standard_error_matches_the_spread_of_rounded_means(sigma):
    """Sessions of 20 holds of 400 rounded samples, true values anywhere within a count: the RMS error of the
    hold means is what mean_standard_error says from the samples' own stds, from noiseless to fully dithered
    (the plain noise/sqrt(n) is 20 times too small at sigma 0)."""
    rng = np.random.default_rng(7)
    x = rng.uniform(-50, 50, (100, 20))
    samples = np.round(x[..., None] + sigma * rng.standard_normal((100, 20, 400)))
    err = samples.mean(axis=2) - x
    predicted = np.array([mean_standard_error(s.std(axis=1)[:, None], np.full(20, 400))[:, 0] for s in samples])
    ratio = np.sqrt(np.mean(err ** 2) / np.mean(predicted ** 2))
    assert 0.9 < ratio < 1.1, ratio


def test_noiseless_quantised_holds_do_not_misfit():
    """A clean simulator's holds (std 0, means rounded) fit to their rounding: no misfit warning, and the
    reported B uncertainty covers the error."""
    rng = np.random.default_rng(4)
    R = Rotation.random(20, random_state=rng).as_matrix()
    K = 400 * (np.eye(3) + 0.02 * rng.standard_normal((3, 3)))
    B = rng.uniform(-300, 300, 3)
    y = np.round(np.einsum("kji,j->ki", R, [0, 0, 9.80665]) @ K.T + B)
    cal = calibrate_joint(y, R, 9.80665, y_std=np.zeros((20, 3)), counts=np.full(20, 500))
    assert not [w for w in cal.warnings if "misfit" in w]
    assert cal.extra["reduced_chi2"] < 5
    assert np.all(np.abs(cal.B - B) < 4 * cal.B_std)
