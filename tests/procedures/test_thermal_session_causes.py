"""The thermal session's own analysis of its steps: `rig calibrate --sim --thermal` on a unit without thermal
hysteresis names no thermal cause, on a unit with one names and sizes it, and the verdict is printed and kept in
the thermal folder's manifest."""

import json
from dataclasses import replace

import numpy as np
import pytest

from rig.commands.thermal_run import builtin_thermal_config, run_thermal_to
from rig.effects import THERMAL_HYSTERESIS, THERMAL_LAG
from rig.io.calibration_json import read_calibration
from rig.units import REPORT_UNITS

DETECTABLE = 5.0        # a half-width this many times a step's stated bias deviation must be seen


def built_in(hysteresis: bool):
    """The built-in thermal session (its set points, soak threshold and schedule) sampled at half the rate and its
    soaks polled every 10 s, to keep the test short: each step's deviations grow by about 1.4, which the checks
    below take from the steps themselves."""
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, sim_hysteresis=hysteresis, poll_s=10.0)
    config.schedule.rate_hz = 50.0
    config.schedule.mag_every = 1
    return config


def test_a_clean_unit_thermal_session_names_no_thermal_cause(tmp_path):
    config = built_in(hysteresis=False)
    printed: list[str] = []
    code = run_thermal_to(tmp_path / "t", config, sim=True, seed=5, progress=False,
                          echo=lambda line="", **_: printed.append(str(line)))
    assert code == 0
    manifest = json.loads((tmp_path / "t" / "thermal.json").read_text())
    causes = manifest["causes"]
    assert set(causes) == set(manifest["temperature_model"])         # every modelled sensor was analysed
    for sensor, verdict in causes.items():
        assert verdict["p"], sensor                                    # tested, not skipped
        assert verdict["findings"] == [] and verdict["undistinguished"] == [], (sensor, verdict)
    for line in manifest["causes_lines"]:
        assert line in printed


def test_the_built_in_thermal_session_names_and_sizes_the_hysteresis_its_unit_carries(tmp_path):
    """Blind: the simulated unit's seed draws a hysteresis of realistic size per sensor (`sim_hysteresis`); the
    session's analysis sees only its steps. Read back afterwards from the steps' truth: where the drawn half-width
    is at least DETECTABLE times the deviation a step states for its bias, `thermal_hysteresis` is named and sized
    within 40 %; where it is smaller it may go unnamed, but what is named is sized as well; a lag is never named."""
    assert builtin_thermal_config().thermal.sim_hysteresis            # the built-in session's unit carries one
    config = built_in(hysteresis=True)
    printed: list[str] = []
    code = run_thermal_to(tmp_path / "t", config, sim=True, seed=3, progress=False,
                          echo=lambda line="", **_: printed.append(str(line)))
    assert code == 0, printed
    manifest = json.loads((tmp_path / "t" / "thermal.json").read_text())
    first = tmp_path / "t" / manifest["steps"][0]["folder"]
    truth = json.loads((first / "truth.json").read_text())
    drawn = {e["sensor"]: e["magnitude"] for e in truth["effects"] if e["effect"] == THERMAL_HYSTERESIS}
    stated = {}
    for step in manifest["steps"]:
        cal = read_calibration(tmp_path / "t" / step["folder"] / "calibration.json")
        for sensor, entry in cal["sensors"].items():
            per_count = 1.0 / truth["sensors"][sensor]["counts_per_unit"] / REPORT_UNITS[sensor][1]
            stated.setdefault(sensor, []).append(float(np.max(entry["B_std"])) * per_count)
    must = {s for s, size in drawn.items() if size >= DETECTABLE * np.median(stated[s])}
    assert must, (drawn, stated)                             # the check is not vacuous
    for sensor, verdict in manifest["causes"].items():
        named = {f["effect"]: f for f in verdict["findings"]}
        assert THERMAL_LAG not in named, (sensor, verdict)
        if sensor in must:
            assert THERMAL_HYSTERESIS in named, (sensor, drawn[sensor], verdict["p"], verdict["notes"])
        if THERMAL_HYSTERESIS in named:
            size = named[THERMAL_HYSTERESIS]["magnitude"]
            assert size == pytest.approx(drawn[sensor], rel=0.40), (sensor, size, drawn[sensor])
    assert any(THERMAL_HYSTERESIS in line for line in printed)
