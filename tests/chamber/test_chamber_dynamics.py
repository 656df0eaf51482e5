"""The fake chamber's thermal dynamics against their closed forms (docstring of fixtures/chamber/thermal.py).

A first-order lag (time constant tau) following a ramp of rate r trails it by r*tau once the start-up
transient has died; after the ramp ends its error r*tau decays as exp(-t/tau). So the air, read through our
client, comes within `tol` of the set point at ramp_time + tau*ln(r*tau/tol).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fixtures.chamber import ChamberServer, FakeChamber, ThermalParameters
from rig.chamber import ChamberLink
from rig.clock import SimClock


def test_air_reaches_the_set_point_when_the_ramp_predicts():
    clock = SimClock()
    params = ThermalParameters(air_tau_s=30.0)
    chamber = FakeChamber(clock, params=params)
    rate, start, target, tol, poll = 2.0, 23.0, 63.0, 0.3, 1.0
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock, poll_interval=poll) as link:
        t0 = clock.now()
        link.ramp_rate(rate)
        link.set_point(target)
        link.run()
        link.wait_air(target, tol, timeout=7200.0)
        took = clock.now() - t0
    lag_c = rate / 60.0 * params.air_tau_s
    predicted = (target - start) / (rate / 60.0) + params.air_tau_s * math.log(lag_c / tol)
    assert took == pytest.approx(predicted, abs=poll + 2.0), (took, predicted)


def test_heating_power_limits_a_step_and_the_air_settles_on_the_set_point():
    clock = SimClock()
    params = ThermalParameters(heat_c_per_min=6.0, cool_c_per_min=4.0)
    chamber = FakeChamber(clock, params=params)
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock) as link:
        link.ramp_rate(0)
        link.set_point(83.0)
        link.run()
        t = np.arange(0.0, 1800.0, 5.0)
        air = np.array([chamber.temperatures(clock.now() + dt)[0] for dt in t])
    slope = np.diff(air) / np.diff(t) * 60.0
    assert slope.max() == pytest.approx(6.0, rel=0.01), "heating power caps the rate of the air"
    assert air[-1] == pytest.approx(83.0, abs=0.01)


def test_die_lags_the_air_and_runs_its_self_heating_above_it_at_steady_state():
    clock = SimClock()
    params = ThermalParameters(air_tau_s=30.0, fixture_tau_s=300.0, die_tau_s=40.0, die_self_heating_c=3.0,
                               heat_c_per_min=1000.0)
    chamber = FakeChamber(clock, params=params)
    chamber.faults.clear()
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock) as link:
        link.ramp_rate(0)
        link.set_point(43.0)
        link.run()
        t0 = clock.now()
        times = t0 + np.arange(0.0, 4 * 3600.0, 1.0)
        temps = np.array([chamber.temperatures(t) for t in times])
    air, fixture, die = temps.T
    rise = 20.0

    def time_to(x: np.ndarray, base: float, fraction: float) -> float:
        return float(times[np.argmax(x - base >= fraction * rise)] - t0)

    t_air, t_fix, t_die = (time_to(x, b, 1 - math.exp(-1)) for x, b in ((air, 23.0), (fixture, 23.0),
                                                                        (die, 26.0)))
    assert t_air == pytest.approx(30.0, abs=2.0)
    assert t_air < t_fix < t_die, "the fixture lags the air, the die the fixture"
    assert t_fix == pytest.approx(30.0 + 300.0, rel=0.1), "lags in series: about the sum of their time constants"
    assert t_die - t_fix == pytest.approx(40.0, rel=0.25)
    assert die[-1] - air[-1] == pytest.approx(3.0, abs=0.01)
    assert fixture[-1] == pytest.approx(air[-1], abs=0.01)


def test_a_stopped_chamber_drifts_back_to_the_room():
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock) as link:
        link.set_point(60.0)
        link.run()
        link.wait_air(60.0, 0.5, timeout=3600.0)
        link.stop()
        air_stopped = link.air_c()
        clock.sleep(3 * chamber.params.idle_tau_s)
        air_later = link.air_c()
    expected = 23.0 + (air_stopped - 23.0) * math.exp(-3)
    assert air_later == pytest.approx(expected, abs=0.05)
