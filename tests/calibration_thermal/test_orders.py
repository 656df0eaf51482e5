"""The order of each term is found from held-out temperatures, blind: a linear curve gets 1, a cubic 3, a unit
that does not move with temperature 0."""

import numpy as np
import pytest

from rig.calibration.thermal import fit_thermal_model

from thermal_synth import make_unit, thermal_steps

UNITS = 8


def _orders(sensor: str, shape: str, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    B, H = [], []
    for _ in range(UNITS):
        model = fit_thermal_model(sensor, thermal_steps(make_unit(sensor, rng, shape), rng))
        B.extend(model.B.orders)
        H.append(model.H.orders[0])
    return np.asarray(B), np.asarray(H)


@pytest.mark.parametrize("sensor", ["accel", "gyro"])
def test_linear_bias_gets_order_one(sensor):
    B, H = _orders(sensor, "linear", 21)
    assert np.mean(B == 1) >= 0.7
    assert np.mean(H == 1) >= 0.7


@pytest.mark.parametrize("sensor", ["accel", "gyro"])
def test_cubic_bias_gets_order_three(sensor):
    B, _ = _orders(sensor, "cubic", 22)
    assert np.mean(B == 3) >= 0.9


@pytest.mark.parametrize("sensor", ["accel", "gyro"])
def test_no_false_order_on_a_unit_that_does_not_move(sensor):
    B, H = _orders(sensor, "flat", 23)
    assert np.mean(B == 0) >= 0.7
    assert np.mean(H == 0) >= 0.7
