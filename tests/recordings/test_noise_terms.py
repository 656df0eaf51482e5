"""Which noise terms a still record determines (`rig.noise.terms`, `rig.noise.analysis`): synthetic still logs of
known white noise, random walk and flicker floor, long and short; the terms they hold are fitted at their sizes,
those the record is too short for are said not determinable (below a bound the true size keeps under), and nothing
but the white noise is named on white noise.

A fitted coefficient is checked against its stated deviation. Those deviations take the octave taus' Allan
variances as independent; over 60 simulated 20-minute random walks the stated deviation of K was 0.0027 where
the scatter was 0.0048 (their mean 0.0499 for 0.05), so the checks allow five stated deviations."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from still_synth import RATE_HZ, flicker, random_walk, session, times, white, with_term  # noqa: E402

from fixtures.world.effects.noise import BiasInstability  # noqa: E402
from rig.noise.allan import allan_deviation  # noqa: E402
from rig.noise.analysis import analyse_still  # noqa: E402
from rig.noise.terms import ABSENT, FITTED, MIN_CLUSTERS, NOT_DETERMINABLE, determine_terms  # noqa: E402
from rig.noise.warm_up import find_warm_up  # noqa: E402

N0 = 0.2              # unit per sqrt(Hz): 2 units a sample at 100 Hz
STATED = 5.0          # stated deviations a fitted coefficient may be off (module docstring)


def terms(x: np.ndarray):
    return determine_terms(allan_deviation(x, RATE_HZ), len(x) / RATE_HZ).terms


def close(term, truth: float) -> bool:
    return term.status == FITTED and abs(term.value - truth) <= STATED * term.std


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_white_noise_alone_gives_its_density_and_names_nothing_else(seed):
    found = terms(white(np.random.default_rng(seed), int(1200 * RATE_HZ), N0))
    assert close(found["N"], N0), found["N"]
    assert found["Q"].status == ABSENT
    assert found["B"].status == NOT_DETERMINABLE and found["K"].status == NOT_DETERMINABLE
    assert found["B"].value is None and found["K"].value is None and found["B"].bound > 0


@pytest.mark.parametrize("seed", [4, 5, 6])
def test_a_random_walk_is_fitted_from_20_minutes_and_not_determinable_from_30_seconds(seed):
    """K = 0.05 beside N = 0.2: the walk rules the Allan deviation from sqrt(3) N / K = 7 s on, a tau 20 minutes
    hold 170 clusters of and 30 seconds four."""
    K0 = 0.05
    rng = np.random.default_rng(seed)
    n = int(1200 * RATE_HZ)
    found = terms(white(rng, n, N0) + random_walk(rng, n, K0))
    assert close(found["K"], K0) and close(found["N"], N0), (found["K"], found["N"])
    assert found["B"].status != FITTED and found["Q"].status == ABSENT
    short = terms(white(rng, int(30 * RATE_HZ), N0) + random_walk(rng, int(30 * RATE_HZ), K0))
    assert short["K"].status == NOT_DETERMINABLE and short["K"].bound >= K0, short["K"]
    assert close(short["N"], N0)


@pytest.mark.parametrize("seed", [7, 8, 9])
def test_a_flicker_floor_is_fitted_from_20_minutes_and_not_determinable_from_30_seconds(seed):
    """B = 0.1 beside N = 0.2: the floor 0.664 B rules from (N / 0.664 B)^2 = 9 s on, a tau 20 minutes hold 130
    clusters of and 30 seconds three."""
    B0 = 0.1
    rng = np.random.default_rng(seed)
    n = int(1200 * RATE_HZ)
    found = terms(white(rng, n, N0) + flicker(rng, n, B0))
    assert close(found["B"], B0) and close(found["N"], N0), (found["B"], found["N"])
    assert found["K"].status != FITTED and found["Q"].status == ABSENT
    m = int(30 * RATE_HZ)
    short = terms(white(rng, m, N0) + flicker(rng, m, B0))
    assert short["B"].status == NOT_DETERMINABLE and short["B"].bound >= B0, short["B"]


def test_a_term_is_fitted_only_where_it_rules_a_tau_the_record_holds_enough_clusters_of():
    rng = np.random.default_rng(10)
    n = int(1200 * RATE_HZ)
    found = terms(white(rng, n, N0) + random_walk(rng, n, 0.05))
    low, _ = found["K"].ruling_tau_s
    assert 1200 / low >= MIN_CLUSTERS
    assert found["N"].ruling_tau_s[0] == pytest.approx(1 / RATE_HZ)


def test_a_gauss_markov_bias_is_read_as_a_floor_and_leans_on_no_other_term():
    """The simulated world's bias instability (a Gauss-Markov bias, a hump in the Allan deviation, not a floor):
    its floor is fitted under the hump's top, and the model's bend around the hump names no quantisation."""
    t = times(3600)
    rng = np.random.default_rng(11)
    term = BiasInstability("accel", sigma=np.full(3, 0.2), tau_s=10.0, seed=11)
    x = with_term(term, t, np.column_stack([white(rng, len(t), N0) for _ in range(3)]))
    for k in range(3):
        found = terms(x[:, k])
        peak = term.magnitude()                    # the flicker floor whose Allan deviation is the hump's top
        assert found["B"].status == FITTED and 0.5 * peak <= found["B"].value <= peak, (found["B"], peak)
        assert found["Q"].status == ABSENT and found["K"].status != FITTED
        assert close(found["N"], N0)


@pytest.mark.parametrize("kind", ["white", "random walk", "flicker", "gauss-markov"])
def test_no_warm_up_is_named_on_noise_that_wanders_as_much_later_as_at_its_start(kind):
    t = times(600)
    for seed in range(8):
        rng = np.random.default_rng(100 + seed)
        x = white(rng, len(t), N0)
        if kind == "random walk":
            x = x + random_walk(rng, len(t), 0.05)
        elif kind == "flicker":
            x = x + flicker(rng, len(t), 0.1)
        elif kind == "gauss-markov":
            x = x + with_term(BiasInstability("accel", sigma=np.full(3, 0.5), tau_s=30.0, seed=seed), t,
                              np.zeros((len(t), 3)))[:, 0]
        assert find_warm_up(t, x) is None, (kind, seed, find_warm_up(t, x))


def test_the_analysis_names_no_warm_up_and_fits_only_the_white_noise_of_a_white_log():
    t = times(900)
    rng = np.random.default_rng(12)
    log = session(t, {"accel": np.column_stack([9.8 * (k == 2) + white(rng, len(t), 3e-4) for k in range(3)])},
                  {"accel": "m/s^2"})
    report = analyse_still(log)
    assert report["spans"]["accel"] == {"start_s": 0.0, "end_s": pytest.approx(t[-1]), "after_warm_up": False}
    for axis, fit in report["sensors"]["accel"].items():
        assert fit["start_trend"] is None
        assert {k: v["status"] for k, v in fit["terms"].items()} == {"Q": ABSENT, "N": FITTED, "B": NOT_DETERMINABLE,
                                                                    "K": NOT_DETERMINABLE}
        assert fit["B"] is None and fit["K"] is None and fit["N"] > 0
