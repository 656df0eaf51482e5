"""The thermal session's own analysis of its steps: `rig calibrate --sim --thermal` on a unit without thermal
hysteresis names no thermal cause, and the verdict is printed and kept in the thermal folder's manifest."""

import json
from dataclasses import replace

from rig.commands.thermal_run import builtin_thermal_config, run_thermal_to


def test_a_clean_unit_thermal_session_names_no_thermal_cause(tmp_path):
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, sim_hysteresis=False)
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
