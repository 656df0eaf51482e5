"""Held out between the fitted temperatures: within 1.2x of what noise alone leaves, better than the peers.

"What noise alone leaves" is the error of the same generalised least squares told the true curves' orders,
fitted to the same noisy steps (comparison.py); the figures are RMS over units and held-out temperatures.
"""

import numpy as np
import pytest

from comparison import campaign, rms

UNITS = {"accel": 6, "gyro": 12}
BIAS, SCALE, OUTPUT = 0, 1, 2


@pytest.fixture(scope="module", params=["accel", "gyro"])
def results(request):
    return request.param, campaign(request.param, UNITS[request.param], seed=31)


def test_within_1_2x_of_the_noise_floor(results):
    sensor, c = results
    ours, floor = rms(c["ours"], (0, 1)), rms(c["true_orders"], (0, 1))
    assert ours[BIAS] <= 1.2 * floor[BIAS], (sensor, ours, floor)
    assert ours[SCALE] <= 1.2 * floor[SCALE], (sensor, ours, floor)


def test_better_than_both_peers_at_every_held_out_temperature(results):
    sensor, c = results
    ours = rms(c["ours"], 0)
    for peer in ("px4", "ardupilot"):
        theirs = rms(c[peer], 0)
        assert np.all(ours[:, OUTPUT] < theirs[:, OUTPUT]), (sensor, peer, ours[:, OUTPUT], theirs[:, OUTPUT])
        assert np.all(ours[:, SCALE] < theirs[:, SCALE]), (sensor, peer)
