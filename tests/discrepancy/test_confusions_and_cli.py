"""Known confusions are named, not guessed; the statistics helpers; the command line."""

import json

import numpy as np
from click.testing import CliRunner

from rig.commands.discrepancy import discrepancy
from rig.discrepancy.stats import holm, prewhiten
from rig.io.session_writer import write_session
from tests.discrepancy.conftest import session_for


def test_temperature_that_only_rises_with_time_is_reported_as_ambiguous_with_drift():
    ramp = lambda t: 25.0 + 0.04 * np.asarray(t)   # noqa: E731 - T exactly collinear with t
    session, _ = session_for([("temperature_bias", "accel")], 3, temperature=ramp)
    from tests.discrepancy.conftest import blind
    report = blind(session)
    (f,) = [f for f in report["findings"] if f["sensor"] == "accel"]
    assert f["effect"] in ("temperature_bias", "bias_drift")
    other = "bias_drift" if f["effect"] == "temperature_bias" else "temperature_bias"
    assert f.get("ambiguous_with") == [other]


def test_holm_adjusts_step_down():
    adj = holm([0.01, 0.04, 0.03, 0.2])
    np.testing.assert_allclose(adj, [0.04, 0.09, 0.09, 0.2])


def test_prais_winsten_whitens_an_ar1_series():
    rng = np.random.default_rng(0)
    e = np.zeros(4000)
    for i in range(1, e.size):
        e[i] = 0.7 * e[i - 1] + rng.standard_normal()
    w = prewhiten(e, np.zeros(e.size, int), {0: 0.7})
    lag1 = np.dot(w[1:], w[:-1]) / np.dot(w, w)
    assert abs(lag1) < 0.05
    assert abs(np.dot(e[1:], e[:-1]) / np.dot(e, e) - 0.7) < 0.05


def test_command_reads_an_interchange_folder_and_writes_the_report(tmp_path):
    session, _ = session_for([("gyro_g_sensitivity", "gyro")], 0)
    folder = write_session(session, tmp_path / "session", extra_meta={"truth": None})
    out = tmp_path / "out" / "discrepancy.json"
    result = CliRunner().invoke(discrepancy, [str(folder), "--json", str(out), "--report", str(tmp_path / "plots"),
                                              "--no-replay"])
    assert result.exit_code == 0, result.output
    report = json.loads(out.read_text())
    assert report["schema"] == "rig-discrepancy/1"
    assert [f["effect"] for f in report["findings"]] == ["gyro_g_sensitivity"]
    assert "gyro_g_sensitivity" in result.output
    assert (tmp_path / "plots" / "gyro-gyro_g_sensitivity.png").stat().st_size > 1000


def test_command_names_the_broken_file(tmp_path):
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "meta.json").write_text("{}")
    (tmp_path / "bad" / "samples.csv").write_text("t\n")
    result = CliRunner().invoke(discrepancy, [str(tmp_path / "bad"), "--json", str(tmp_path / "o.json")])
    assert result.exit_code == 2
    assert "meta.json" in result.output


def _sweep_session(outer_angles, effects, seed=4):
    """Inner-axis sweeps at a few outer angles: all inner moves one way, one long return move."""
    from fixtures.world.draw import draw_effect
    from fixtures.world.model import random_sensor_models
    from fixtures.world.session_sim import SessionPlan, simulate_session

    rng = np.random.default_rng(seed)
    drawn = [draw_effect(name, rng, sensor=sensor) for name, sensor in effects]
    schedule = [(a, b) for a in outer_angles for b in np.linspace(-150, 150, 10)]
    session, _ = simulate_session(random_sensor_models(rng), SessionPlan(schedule, speed_dps=90, accel_dps2=200),
                                  effects=drawn, seed=seed)
    return session, drawn


def test_one_way_sweeps_give_no_false_rate_effect():
    """Few outer moves and one-signed inner moves: the gyro's x/y scale rests on a handful of windows,
    where a careless positive-rate column or reference rate fakes an asymmetry or a latency."""
    from tests.discrepancy.conftest import blind
    session, _ = _sweep_session((30.0, 70.0, 120.0), [])
    assert blind(session)["findings"] == []


def test_motor_field_that_looks_like_soft_iron_is_reported_unidentifiable():
    """With only two outer angles, Rz(-inner) d is a combination of the geomagnetic reference's
    columns: the report must say the data cannot tell it from soft iron, not claim or deny it."""
    from tests.discrepancy.conftest import blind
    session, _ = _sweep_session((30.0, 70.0), [("table_magnetic_disturbance", "mag")])
    report = blind(session)
    assert report["findings"] == []
    assert any(u.startswith("table_magnetic_disturbance on mag") for u in report["unidentifiable"])
    session, (effect,) = _sweep_session((30.0, 70.0, 120.0), [("table_magnetic_disturbance", "mag")])
    (f,) = blind(session)["findings"]
    assert f["effect"] == "table_magnetic_disturbance"
    assert abs(f["magnitude"] - abs(effect.d[1])) < 0.1 * abs(effect.d[1])


def test_isotropic_g_sensitivity_is_not_taken_for_the_earth_rate():
    """Gs = c I has exactly the columns of a vertical Earth rate; the Earth's known 15 deg/h rules it out."""
    from fixtures.world.draw import standard_plan
    from fixtures.world.effects import DEG, G0
    from fixtures.world.effects.gyro_g_sensitivity import GyroGSensitivity
    from fixtures.world.model import random_sensor_models
    from fixtures.world.session_sim import simulate_session
    from tests.discrepancy.conftest import blind

    rng = np.random.default_rng(4)
    effect = GyroGSensitivity(sensor="gyro", Gs=np.eye(3) * 0.06 * DEG / G0)
    session, _ = simulate_session(random_sensor_models(rng), standard_plan(seed=4), effects=[effect], seed=4)
    report = blind(session)
    assert [f["effect"] for f in report["findings"]] == ["gyro_g_sensitivity"]
    assert abs(report["findings"][0]["magnitude"] - 0.06) < 0.01
    earth = next(c for c in report["candidates"] if c["effect"] == "earth_rotation")
    assert "not the Earth" in earth["implausible"]
