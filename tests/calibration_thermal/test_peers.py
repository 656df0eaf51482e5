"""The peers as their published methods say: a cubic offset reproduced, clamped at their limits, ArduPilot's bins."""

import numpy as np
import pytest

from rig.calibration.thermal.peers import (ARDUPILOT_REFERENCE_C, ardupilot_bins, ardupilot_offset_fit,
                                           px4_offset_fit)

T = np.linspace(-10.0, 65.0, 7)


def _cubic(t):
    x = (np.asarray(t, float) - 25.0) / 35.0
    return np.stack([100 + 30 * x - 5 * x ** 3, -40 + 8 * x ** 2, 12 * x + 20 * x ** 3], axis=-1)


@pytest.mark.parametrize("fit", [px4_offset_fit, ardupilot_offset_fit])
def test_a_cubic_offset_is_reproduced_and_anchored_at_the_calibration(fit):
    offsets = _cubic(T)
    B_cal = offsets[3] + np.array([0.5, -0.5, 0.25])     # the normal calibration's own offset at T_cal
    peer = fit(T, offsets, B_cal, np.eye(3), T[3])
    for t in (-3.0, 21.0, 58.0):
        want = B_cal + _cubic(t) - _cubic(T[3])
        np.testing.assert_allclose(peer.B_at(t), want, atol=1e-9 * np.abs(want).max())
    np.testing.assert_allclose(peer.H_at(40.0), np.eye(3))


def test_px4_reference_is_the_middle_and_arduplot_35_without_constant():
    px4 = px4_offset_fit(T, _cubic(T), np.zeros(3), np.eye(3), 25.0)
    ap = ardupilot_offset_fit(T, _cubic(T), np.zeros(3), np.eye(3), 25.0)
    assert px4.reference_c == pytest.approx(27.5) and (px4.tmin_c, px4.tmax_c) == (T[0], T[-1])
    assert ap.reference_c == ARDUPILOT_REFERENCE_C
    assert np.all(ap.coefficients[:, 0] == 0.0)


@pytest.mark.parametrize("fit", [px4_offset_fit, ardupilot_offset_fit])
def test_temperatures_beyond_the_limits_are_clamped(fit):
    peer = fit(T, _cubic(T), np.zeros(3), np.eye(3), 25.0)
    np.testing.assert_allclose(peer.B_at(90.0), peer.B_at(T[-1]))
    np.testing.assert_allclose(peer.B_at(-40.0), peer.B_at(T[0]))


def test_ardupilot_bins_close_at_100_samples_and_half_a_degree():
    rng = np.random.default_rng(2)
    temps = np.repeat(20.0 + 0.25 * np.arange(12), 60)       # 60 samples per quarter degree
    samples = rng.normal(0, 1, (temps.size, 3))
    t_bins, means = ardupilot_bins(temps, samples)
    assert means.shape == (t_bins.size, 3)
    assert np.all(np.diff(t_bins) >= 0.5 - 1e-9)
    first = 120                                              # 100 samples reached at 20.25 C; 0.5 C rise at 20.5
    np.testing.assert_allclose(means[0], samples[:first + 1].mean(axis=0))
    assert t_bins[0] == pytest.approx(0.5 * (20.0 + 20.5))
