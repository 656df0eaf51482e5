"""The simulated sensing element's lag behind the die thermometer (`fixtures.world.heat.LaggedElement`) against the
first-order lag's closed form: on a ramp it trails by r tau (1 - exp(-t / tau)), after a step it closes the gap as
exp(-t / tau), whatever order the times are asked in."""

import numpy as np
import pytest

from fixtures.world.heat import LaggedElement

TAU_S = 90.0


def test_on_a_ramp_the_element_trails_the_die_by_the_rate_times_the_lag():
    rate = 0.5 / 60.0
    die = lambda t: 30.0 + rate * np.clip(np.asarray(t, dtype=float) - 100.0, 0.0, None)  # noqa: E731
    element = LaggedElement(die, TAU_S, 0.0)
    times = np.array([1000.0, 150.0, 400.25, 1000.0, 999.9, 2000.0])         # any order, repeats
    got = np.array([element(t) for t in times])
    dt = np.clip(times - 100.0, 0.0, None)
    want = die(times) - rate * TAU_S * (1.0 - np.exp(-dt / TAU_S))
    # a time before the integration's last point is read linearly between points STEP_S apart: off by at most
    # STEP_S^2 / 8 times the curvature, rate / tau at most
    between = LaggedElement.STEP_S ** 2 / 8.0 * rate / TAU_S
    assert got == pytest.approx(want, abs=between + 1e-12)
    assert element(times) == pytest.approx(want, abs=between + 1e-12)


def test_after_a_step_of_the_die_the_element_closes_the_gap_exponentially():
    die = lambda t: np.where(np.asarray(t, dtype=float) >= 10.0, 50.0, 20.0)  # noqa: E731
    element = LaggedElement(die, TAU_S, 0.0)
    t = np.array([10.5, 60.0, 300.0])
    # integrated as linear between points STEP_S apart: the step is a ramp over the one before it (9.5 to 10 s)
    h = t - 10.0
    ramp = 30.0 / LaggedElement.STEP_S
    first = 20.0 + ramp * (LaggedElement.STEP_S - TAU_S * (1.0 - np.exp(-LaggedElement.STEP_S / TAU_S)))
    want = 50.0 - (50.0 - first) * np.exp(-h / TAU_S)
    assert element(t) == pytest.approx(want, abs=1e-9)


def test_a_lag_that_is_not_positive_is_refused():
    with pytest.raises(ValueError, match="tau_s"):
        LaggedElement(lambda t: np.asarray(t) * 0.0, 0.0, 0.0)
