"""Hidden-effect tests run blind: draw an effect at a realistic size, simulate, analyse, compare."""

import pytest

from fixtures.world.draw import hidden_effect_cases
from rig.discrepancy.search import GAIN_MIN

from tests.discrepancy.conftest import blind, identifiable_magnitude, session_for

# (effect, sensor, session design): every drawable effect of the registry, so a new effect is tested blind too;
# these two have their own tests below (a gyro's temperature scale needs a larger excursion than seeds 0-1 give,
# the Earth's rate long holds and a quiet gyro)
OWN_TESTS = {("temperature_scale", "gyro"), ("earth_rotation", "gyro")}
CASES = [case for case in hidden_effect_cases() if case[:2] not in OWN_TESTS]
REL_TOL = 0.25
SIGMAS = 4.0


def check_found(report, effect, sensor):
    names = [(f["effect"], f["sensor"]) for f in report["findings"]]
    assert (effect.name, sensor) in names, f"expected {effect.name} on {sensor}, found {names}"
    f = next(f for f in report["findings"] if (f["effect"], f["sensor"]) == (effect.name, sensor))
    truth = identifiable_magnitude(effect)
    err = abs(abs(f["magnitude"]) - abs(truth))
    assert err <= max(REL_TOL * abs(truth), SIGMAS * f["uncertainty"]), (f["magnitude"], f["uncertainty"], truth)
    assert f["heldout_rms_after"] < (1.0 - GAIN_MIN) * f["heldout_rms_before"]
    assert f["unit"] == effect.unit() or effect.name in ("temperature_bias", "bias_drift")
    return f


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("name,sensor,design", CASES, ids=[f"{n}-{s}" for n, s, _ in CASES])
def test_hidden_effect_is_named_sized_and_improves_heldout(name, sensor, design, seed):
    session, (effect,) = session_for([(name, sensor)], seed, **design)
    report = blind(session)
    check_found(report, effect, sensor)
    assert len(report["findings"]) == 1, [f["effect"] for f in report["findings"]]


def test_temperature_scale_of_a_gyro_is_found_with_a_large_excursion():
    session, (effect,) = session_for([("temperature_scale", "gyro")], 3, research_env=True)
    check_found(blind(session), effect, "gyro")


def test_earth_rate_is_found_by_a_quiet_gyro_with_long_holds():
    session, (effect,) = session_for([("earth_rotation", "gyro")], 2, hold_s=30.0, gyro_noise=0.0018)
    report = blind(session)
    f = check_found(report, effect, "gyro")
    assert "gyro_g_sensitivity" not in [g["effect"] for g in report["findings"]]
    assert f["unit"] == "deg/h"


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_clean_session_gives_no_finding(seed):
    session, _ = session_for([], seed)
    report = blind(session)
    assert report["findings"] == []
    assert report["schema"] == "rig-discrepancy/1"
    assert {c["effect"] for c in report["candidates"]} >= {"gyro_g_sensitivity", "temperature_bias",
                                                         "mag_offset_flip", "time_offset"}


@pytest.mark.parametrize("pair", [
    [("temperature_bias", "accel"), ("gyro_g_sensitivity", "gyro")],
    [("time_offset", "gyro"), ("mag_offset_flip", "mag")],
    [("supply_ratiometric", "accel"), ("accel_scale_nonlinearity", "accel")],
    [("gyro_g_sensitivity", "gyro"), ("gyro_scale_asymmetry", "gyro")],
], ids=lambda p: "+".join(n for n, _ in p))
def test_two_effects_are_both_found(pair):
    session, effects = session_for(pair, 5)
    report = blind(session)
    for (name, sensor), e in zip(pair, effects):
        check_found(report, e, sensor)
    assert len(report["findings"]) == 2
