"""The one registry of effects (rig.effects): every name has its simulator term, its draw range and its candidate
test, or says why it has none; an effect a recording can show has its law for recordings and its place in the twin;
the vocabulary of docs/reference/effects.md is all in it; units agree wherever an effect is named."""

import re

import numpy as np
import pytest

import fixtures.world  # noqa: F401  (registers every simulator term, the noise ones included)
from fixtures.world.draw import draw_effect, hidden_effect_cases
from fixtures.world.effects_base import EFFECTS as TERMS
from fixtures.world.effects_base import RANGES, Effect, simulator_term
from rig.discrepancy.candidates import CANDIDATES, POSE_REGRESSORS, RECORDING_TESTS, candidate_test
from rig.effects import EFFECTS, TRIADS, effect
from tests.paths import DOCS

MODEL = [n for n, s in EFFECTS.items() if s.family == "model"]
NOISE = [n for n, s in EFFECTS.items() if s.family == "noise"]
SIMULATED = [n for n, s in EFFECTS.items() if s.family != "thermal"]   # thermal ones: the thermal session's world


def _spec_rows() -> dict[str, tuple[list[str], str]]:
    """effect -> (sensors, magnitude cell) of every table row of effects.md."""
    rows = {}
    for line in (DOCS / "reference" / "effects.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and re.fullmatch(r"`[a-z_]+`", cells[0]):
            sensors = [part.strip().split()[0] for part in cells[1].split(",")]
            rows[cells[0].strip("`")] = (sensors, cells[4])
    return rows


def test_every_effect_of_the_spec_is_in_the_registry_with_its_sensors_and_unit():
    rows = _spec_rows()
    assert set(rows) == set(EFFECTS), (sorted(set(rows) - set(EFFECTS)), sorted(set(EFFECTS) - set(rows)))
    for name, (sensors, magnitude) in rows.items():
        spec = effect(name)
        assert list(spec.sensors) == sensors, name
        assert spec.unit.replace("{unit}", "unit") in magnitude, (name, spec.unit, magnitude)


@pytest.mark.parametrize("name", SIMULATED)
def test_every_name_has_its_simulator_term(name):
    term = TERMS[name]
    assert issubclass(term, Effect) and term.name == name
    for sensor in EFFECTS[name].sensors:
        assert term(sensor=sensor).unit() == EFFECTS[name].unit_for(sensor)


@pytest.mark.parametrize("name", MODEL)
def test_every_model_effect_has_a_draw_range_per_sensor_and_a_candidate_test(name):
    spec = EFFECTS[name]
    assert name in CANDIDATES and not spec.no_candidate
    for sensor in spec.sensors:
        lo, hi = RANGES[(name, sensor)]
        assert 0 < lo <= hi


@pytest.mark.parametrize("name", sorted(set(POSE_REGRESSORS) | set(RECORDING_TESTS)))
def test_every_effect_a_recording_can_show_is_added_to_recordings_and_taken_into_the_twin(name):
    term = TERMS[name]
    assert term.recording_sensor in EFFECTS[name].sensors
    lo, hi = RANGES[(name, term.recording_sensor)]
    n = 200
    t = np.linspace(0.0, 100.0, n)
    calibrated = {"accel": np.tile([0.0, 0.0, 9.8], (n, 1)) + np.linspace(-1, 1, n)[:, None],
                  "gyro": np.sin(t)[:, None] * np.ones((n, 3))}
    stream, added = term.into_recording(np.random.default_rng(0), hi, t, calibrated)
    assert stream.shape == (n, 3) and not np.allclose(stream, calibrated[term.recording_sensor]) and added
    assert term.twin_statistics and all(s.split(".")[0] in TRIADS for s in term.twin_statistics)


@pytest.mark.parametrize("name", NOISE)
def test_noise_effects_say_why_they_have_no_candidate_and_no_draw(name):
    assert name not in CANDIDATES
    assert "twin" in EFFECTS[name].no_candidate
    assert not [k for k in RANGES if k[0] == name]


@pytest.mark.parametrize("name,sensor,design", hidden_effect_cases(), ids=lambda c: str(c))
def test_a_drawn_effect_has_the_drawn_size_and_the_units_of_its_candidate(name, sensor, design):
    lo, hi = RANGES[(name, sensor)]
    drawn = draw_effect(name, np.random.default_rng(7), sensor=sensor, duration_s=100.0)
    assert drawn.name == name and lo <= drawn.identifiable_magnitude() <= hi * (1 + 1e-12)
    sized = draw_effect(name, np.random.default_rng(8), sensor=sensor, magnitude=0.5 * (lo + hi))
    assert sized.identifiable_magnitude() == pytest.approx(0.5 * (lo + hi), rel=1e-9)
    truth = sized.truth()
    assert truth["unit"] == EFFECTS[name].unit_for(sensor if sensor in TRIADS else "accel")
    for tested_on in EFFECTS[name].tested_on:
        build, _ = CANDIDATES[name]
        cand = build(tested_on)
        assert cand.magnitude is not None and len(cand.labels) >= 1


def test_every_drawable_sensor_is_one_the_effect_acts_on_and_every_model_effect_is_drawable():
    assert {(n, s) for n, s, _ in hidden_effect_cases()} == {(n, s) for n in MODEL for s in EFFECTS[n].sensors}


def test_a_name_outside_the_vocabulary_cannot_register_a_term_or_a_candidate():
    class Nameless(Effect):
        name = "no_such_effect"

    with pytest.raises(ValueError, match="unknown effect 'no_such_effect'"):
        simulator_term(Nameless)
    with pytest.raises(ValueError, match="unknown effect"):
        candidate_test("no_such_effect")
    with pytest.raises(ValueError, match="needs"):
        candidate_test("bias_drift", needs=("humidity",))


def test_a_range_for_a_sensor_the_effect_does_not_act_on_is_refused():
    class Elsewhere(Effect):
        name = "gyro_g_sensitivity"

    with pytest.raises(ValueError, match="acts on"):
        simulator_term(ranges={"mag": (1.0, 2.0)})(Elsewhere)
    with pytest.raises(ValueError, match="two simulator terms"):
        simulator_term(Elsewhere)


def test_drawing_an_effect_that_is_not_drawn_says_so():
    with pytest.raises(ValueError, match="not drawn"):
        draw_effect("quantisation", np.random.default_rng(0))
    with pytest.raises(ValueError, match="unknown effect"):
        draw_effect("no_such_effect", np.random.default_rng(0))
