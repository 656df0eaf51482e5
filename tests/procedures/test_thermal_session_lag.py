"""A thermal lag named end to end: a simulated thermal session with ramped steps (`[thermal] ramp_c_per_min`) on a
unit whose sensing elements lag its die thermometer (`[thermal] sim_lag_s`) names `thermal_lag` and sizes it, blind;
the same session on a unit without a lag names nothing, and its ramped steps were measured at the ramp's rate.

The shortest session that tells a lag from a hysteresis: two set points above the room, up and down (30, 70, 30 C,
so the first step is approached from below and the two soaked steps at 30 C are of opposite sweeps), and a
ramped step on each move (50 C at +0.5 and -0.5 C/min): the soaked pair sees a hysteresis alone, the ramped pair a
hysteresis and the lag. Sampled at half the built-in rate and polled every 10 s to keep it short."""

import json
from dataclasses import replace

import numpy as np
import pytest

from rig.commands.thermal_run import builtin_thermal_config, run_thermal_to
from rig.effects import THERMAL_HYSTERESIS, THERMAL_LAG
from rig.io.calibration_json import read_calibration
from rig.units import REPORT_UNITS

RAMP_C_PER_MIN = 0.5
LAG_S = 90.0
DETECTABLE = 5.0    # a bias shift (ramp x lag x the bias's slope) this many times a step's stated deviation is seen


def ramped(lag_s: float):
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, steps_c=[30.0, 70.0], direction="up-down", sim_hysteresis=False,
                             ramp_c_per_min=RAMP_C_PER_MIN, sim_lag_s=lag_s, poll_s=10.0)
    config.schedule.rate_hz = 50.0
    config.schedule.mag_every = 1
    return config


def run(tmp_path, lag_s: float, seed: int) -> tuple[dict, list[str]]:
    printed: list[str] = []
    code = run_thermal_to(tmp_path / "t", ramped(lag_s), sim=True, seed=seed, progress=False,
                          echo=lambda line="", **_: printed.append(str(line)))
    assert code == 0, printed
    return json.loads((tmp_path / "t" / "thermal.json").read_text()), printed


def test_a_clean_ramped_thermal_session_measures_its_ramps_and_names_no_thermal_cause(tmp_path):
    manifest, printed = run(tmp_path, 0.0, seed=4)
    slope = manifest["config"]["thermal"]["slope_c_per_min"]
    steps = manifest["steps"]
    assert [s["ramp_c_per_min"] for s in steps] == [0.0, RAMP_C_PER_MIN, 0.0, -RAMP_C_PER_MIN, 0.0]
    for step in steps:       # the die's rate during the holds, from the thermometer over the step's own samples
        assert step["die_c"]["rate_c_per_min"] == pytest.approx(step["ramp_c_per_min"], abs=slope), step
    mids = [s["die_c"]["mean"] for s in steps if s["ramp_c_per_min"]]
    ends = [s["die_c"]["mean"] for s in steps if not s["ramp_c_per_min"]]
    for mid in mids:        # centred on the move's middle, within the die's travel during the step
        travel = RAMP_C_PER_MIN / 60.0 * steps[1]["table_time_s"]
        assert mid == pytest.approx(0.5 * (ends[0] + ends[1]), abs=travel), (mids, ends)
    for sensor, verdict in manifest["causes"].items():
        assert "lag_given_hysteresis" in verdict["p"], (sensor, verdict)      # the lag was tested beside
        assert verdict["distinguishable"], (sensor, verdict["lag_inflation"])  # a hysteresis, and told from it
        assert verdict["findings"] == [] and verdict["undistinguished"] == [], (sensor, verdict)
    assert any("ramped at +0.5 C/min" in line for line in printed)


def test_a_ramped_thermal_session_names_and_sizes_the_lag_its_unit_carries(tmp_path):
    """Blind: the analysis sees the steps only. Read back afterwards from the unit's truth: where the lag shifts a
    ramped step's bias (its rate times the lag times the bias's slope, the largest axis) by DETECTABLE times the
    deviation the steps state for their bias, `thermal_lag` is named and sized within 40 %; what is named is
    sized so everywhere; a hysteresis is never named."""
    manifest, printed = run(tmp_path, LAG_S, seed=3)
    folder = tmp_path / "t" / manifest["steps"][0]["folder"]
    truth = json.loads((folder / "truth.json").read_text())
    assert truth["element_lag_s"] == LAG_S
    shift_c = RAMP_C_PER_MIN / 60.0 * LAG_S
    slope = {e["sensor"]: np.abs(e["params"]["k"]) for e in truth["effects"] if e["effect"] == "temperature_bias"}
    must = set()
    for sensor, k in slope.items():
        per_count = 1.0 / truth["sensors"][sensor]["counts_per_unit"] / REPORT_UNITS[sensor][1]
        stated = np.median([read_calibration(tmp_path / "t" / s["folder"] / "calibration.json")["sensors"][sensor]
                            ["B_std"] for s in manifest["steps"]], axis=0) * per_count
        if np.max(k * shift_c / stated) >= DETECTABLE:
            must.add(sensor)
    assert must, slope                                        # the check is not vacuous
    for sensor, verdict in manifest["causes"].items():
        named = {f["effect"]: f for f in verdict["findings"]}
        assert THERMAL_HYSTERESIS not in named, (sensor, verdict)
        if sensor in must:
            assert THERMAL_LAG in named, (sensor, verdict["p"], verdict["notes"])
        if THERMAL_LAG in named:
            assert named[THERMAL_LAG]["magnitude"] == pytest.approx(LAG_S, rel=0.40), (sensor, named[THERMAL_LAG])
    assert any(THERMAL_LAG in line for line in printed)


def test_a_ramp_too_slow_to_tell_from_a_soak_is_refused_by_name(tmp_path):
    from click.testing import CliRunner

    from rig.cli import main

    bad = tmp_path / "slow-ramp.toml"
    bad.write_text('[thermal]\nsteps_c = [10.0, 30.0]\nslope_c_per_min = 0.1\nramp_c_per_min = 0.15\n[chamber]\n')
    result = CliRunner().invoke(main, ["calibrate", "--config", str(bad), "--out", str(tmp_path / "c")])
    assert result.exit_code == 2 and "ramp_c_per_min" in result.output and str(bad) in result.output
    assert not (tmp_path / "c").exists()


def test_a_move_too_short_for_the_ramp_stops_the_session_by_name_with_the_chamber_safe(tmp_path):
    """30 to 33 C at 1 C/min: the fixture's lag keeps the die from reaching the rate before it passes the move's
    middle; the session stops there (exit 3), the soaked step kept, and a resume is offered."""
    config = ramped(0.0)
    config.thermal = replace(config.thermal, steps_c=[30.0, 33.0], direction="up", ramp_c_per_min=1.0)
    printed: list[str] = []
    code = run_thermal_to(tmp_path / "t", config, sim=True, seed=2, progress=False,
                          echo=lambda line="", **_: printed.append(str(line)))
    assert code == 3, printed
    text = "\n".join(printed)
    assert "ramp_c_per_min" in text and "rig resume" in text, text
    manifest = json.loads((tmp_path / "t" / "thermal.json").read_text())
    assert [s["status"] for s in manifest["steps"]] == ["complete", "soaking", "pending"]


def test_a_ramp_beyond_the_chambers_limit_is_refused_by_name(tmp_path):
    from importlib import resources

    from rig.config import load_config

    packaged = resources.files("rig.chamber").joinpath("profiles", "watlow-f4t.toml").read_text()
    limit = next(line for line in packaged.splitlines() if line.startswith("max_ramp_c_per_min"))
    (tmp_path / "slow-chamber.toml").write_text(packaged.replace(limit, "max_ramp_c_per_min = 0.4"))
    config = tmp_path / "rig.toml"
    config.write_text('[thermal]\nsteps_c = [30.0, 70.0]\nslope_c_per_min = 0.02\nramp_c_per_min = 0.5\n'
                      '[chamber]\nprofile = "slow-chamber.toml"\n')
    with pytest.raises(ValueError, match=r"rig\.toml: \[thermal\] ramp_c_per_min = 0\.5 .*0\.4 C/min"):
        load_config(config)
    config.write_text(config.read_text().replace("ramp_c_per_min = 0.5", "ramp_c_per_min = 0.3"))
    assert load_config(config).thermal.ramp_c_per_min == 0.3
