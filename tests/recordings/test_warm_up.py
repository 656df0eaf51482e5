"""A warm-up hidden in a still log (the simulated world's `warm_up` term, drawn at a realistic size and time) is
found blind by `rig noise`'s analysis: named with its `a` and `tau` within their stated deviations, each sensor
analysed from where it has settled, and not read as bias instability or rate random walk, as it is when the
analysis is told to keep it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from still_synth import flicker, session, times, white, with_term  # noqa: E402

from fixtures.world.effects.warm_up import WarmUp  # noqa: E402
from rig.noise.analysis import analyse_still  # noqa: E402
from rig.noise.terms import FITTED  # noqa: E402
from rig.noise.warm_up import find_warm_up  # noqa: E402

# white noise density of each sensor (unit per sqrt(Hz), the units the log is in) and the unit
NOISE = {"accel": (3e-4, "m/s^2"), "gyro": (1.5e-4, "rad/s"), "mag": (0.03, "uT")}
LEVEL = {"accel": [0.05, -0.1, 9.8], "gyro": [0.001, -0.002, 0.0005], "mag": [20.0, -5.0, 40.0]}
SECONDS = 1800.0           # eight times the longest realistic tau, and a settled half hour's remainder
STATED = 4.0               # over 100 simulated 30-minute logs (a = 0.158, tau = 68 s) the largest error was 3.1
                           # stated deviations for a and 2.6 for tau


def hidden(seed: int, shape: str, floor: float = 0.0):
    """A still log whose three sensors each carry a drawn warm-up (and, with `floor`, a flicker floor B of that
    many white-noise densities); the warm-ups, for the check only."""
    rng = np.random.default_rng(seed)
    t = times(SECONDS)
    streams, truth = {}, {}
    for sensor, (N, _) in NOISE.items():
        noise = np.column_stack([white(rng, len(t), N) + (flicker(rng, len(t), floor * N) if floor else 0.0)
                                 for _ in range(3)])
        truth[sensor] = WarmUp.drawn(rng, sensor, shape=shape)
        streams[sensor] = with_term(truth[sensor], t, np.array(LEVEL[sensor]) + noise)
    return session(t, streams, {s: unit for s, (_, unit) in NOISE.items()}), truth


def window_noise(sensor: str, tau: float) -> float:
    """The white noise of a tau-long mean: what a warm-up's offset is seen against."""
    return NOISE[sensor][0] / np.sqrt(tau)


@pytest.mark.parametrize("seed,shape", [(1, "exponential"), (2, "exponential"), (3, "ramp")])
def test_a_hidden_warm_up_is_found_at_its_size_and_time_and_the_sensor_analysed_after_it(seed, shape):
    log, truth = hidden(seed, shape)
    report = analyse_still(log)
    for sensor, term in truth.items():
        found_any = False
        for k, axis in enumerate("xyz"):
            found = report["sensors"][sensor][axis]["start_trend"]
            a_true = term.a[k]
            if found is None:
                assert abs(a_true) < 40 * window_noise(sensor, term.tau_s), (sensor, axis, a_true)
                continue
            found_any = True
            assert found["shape"] == shape
            assert abs(found["a"] - a_true) <= STATED * found["a_std"], (sensor, axis, found, a_true)
            assert abs(found["tau_s"] - term.tau_s) <= STATED * found["tau_s_std"], (sensor, axis, found, term.tau_s)
        assert found_any, sensor
        k = int(np.argmax(np.abs(term.a)))
        assert report["sensors"][sensor]["xyz"[k]]["start_trend"] is not None, (sensor, term.a)
        span = report["spans"][sensor]
        assert span["after_warm_up"] and span["start_s"] >= (3 * term.tau_s if shape == "exponential" else term.tau_s)
        for axis, fit in report["sensors"][sensor].items():
            statuses = {key: fit["terms"][key]["status"] for key in "BK"}
            assert FITTED not in statuses.values(), (sensor, axis, statuses)


def test_kept_in_the_analysis_the_warm_up_is_read_as_noise_terms_it_is_not():
    """Why the default leaves it out: the same log analysed whole names a walk or a floor on the warm-up's axis."""
    log, truth = hidden(1, "exponential")
    kept = analyse_still(log, skip_warm_up=False)
    for sensor, term in truth.items():
        axis = "xyz"[int(np.argmax(np.abs(term.a)))]
        fit = kept["sensors"][sensor][axis]
        assert fit["start_trend"] is not None
        assert FITTED in {fit["terms"][key]["status"] for key in "BK"}, (sensor, axis, fit["terms"])
    assert not any(span["after_warm_up"] for span in kept["spans"].values())


def test_a_warm_up_above_a_flicker_floor_leaves_the_floor_at_its_size():
    """A flicker floor B = 0.3 N under the warm-ups (ruling the Allan deviation from 25 s on; a gyro's 6 deg/h): the
    floor is fitted, at its size, from the settled part; the warm-up is found as on white noise."""
    log, truth = hidden(4, "exponential", floor=0.3)
    report = analyse_still(log)
    for sensor, term in truth.items():
        axis = "xyz"[int(np.argmax(np.abs(term.a)))]
        fit = report["sensors"][sensor][axis]
        found = fit["start_trend"]
        assert found is not None and abs(found["a"] - term.a["xyz".index(axis)]) <= STATED * found["a_std"]
        B = fit["terms"]["B"]
        assert B["status"] == FITTED and abs(B["value"] - 0.3 * NOISE[sensor][0]) <= STATED * B["std"], (sensor, B)


def test_a_warm_up_that_has_not_settled_within_the_record_is_not_named():
    """tau a third of the record: no settled stretch to tell it from a slow wander, so nothing is named."""
    t = times(300)
    rng = np.random.default_rng(5)
    x = white(rng, len(t), 0.03) + 10.0 * np.exp(-t / 100.0)
    assert find_warm_up(t, x) is None
