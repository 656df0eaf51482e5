"""`rig attitude` on a session whose accelerometer sits 11 cm from the table axes (the independent
simulator's lever_arm variant): with the lever arm from `rig calibrate` compensated, the Table III
targets hold and our UKF beats the ahrs EKF peers on the same data."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

sys.path.insert(0, str(Path(__file__).parents[1] / "independent_vary"))
import vary_sim as vs  # noqa: E402

from rig.commands.attitude import attitude  # noqa: E402

TARGET_DEG = {"roll": 0.2, "pitch": 0.2, "yaw": 0.3}


def total(row: dict) -> float:
    return float(np.sqrt(sum(v * v for v in row["rms_deg"].values())))


def run_attitude(session: Path, calibration: Path, out: Path, *options: str) -> dict:
    res = CliRunner().invoke(attitude, [str(session), "--calibration", str(calibration), "--json", str(out), *options])
    assert res.exit_code == 0, res.output
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def lever_arm_run(tmp_path_factory):
    from rig.pipeline import calibrate_from_dir

    d = tmp_path_factory.mktemp("lever_attitude")
    vs.write_session(vs.generate(vs.config_for("lever_arm"), 3), d / "s")
    calibrate_from_dir(d / "s", d / "cal", echo=lambda *_: None)
    return d, run_attitude(d / "s", d / "cal" / "calibration.json", d / "a.json")


def test_compensated_session_meets_the_targets(lever_arm_run) -> None:
    _, doc = lever_arm_run
    for axis, limit in TARGET_DEG.items():
        assert doc["rms_deg"][axis] <= limit, doc["rms_deg"]


def test_ours_beats_the_ahrs_ekf_peers_on_the_same_compensated_data(lever_arm_run) -> None:
    _, doc = lever_arm_run
    rows = doc["table"]
    ours = next(r for r in rows if r["filter"] == "ukf" and r["calibration"].startswith("ours"))
    ekfs = [r for r in rows if r["filter"].startswith("ekf")]
    assert len(ekfs) >= 2
    for r in ekfs:
        assert total(ours) < total(r), (r["label"], total(ours), total(r))
    compensated = [r["filter_summary"]["lever_arm_compensated_m"] for r in [ours, *ekfs]]
    assert all(c is not None and c == compensated[0] for c in compensated), compensated
    assert np.abs(np.array(compensated[0]) - vs.config_for("lever_arm").lever_arm_m).max() < 1e-3


def test_without_the_compensation_the_same_session_misses_the_targets(lever_arm_run) -> None:
    """The lever arm, not something else, is what the compensation fixes: drop it from the file and the
    moves' centripetal and tangential accelerations are read as tilt again."""
    d, _ = lever_arm_run
    doc = json.loads((d / "cal" / "calibration.json").read_text())
    for key in ("lever_arm_m", "lever_arm_std_m", "lever_arm_significant", "lever_arm_p_value", "lever_arm_rows"):
        doc["sensors"]["accel"].pop(key)
    (d / "plain.json").write_text(json.dumps(doc))
    plain = run_attitude(d / "s", d / "plain.json", d / "a_plain.json", "--no-peers")
    assert any(plain["rms_deg"][axis] > limit for axis, limit in TARGET_DEG.items()), plain["rms_deg"]
    ours = next(r for r in plain["table"] if r["filter"] == "ukf")
    assert ours["filter_summary"]["lever_arm_compensated_m"] is None


def test_a_malformed_lever_arm_is_refused_naming_the_field(lever_arm_run) -> None:
    d, _ = lever_arm_run
    doc = json.loads((d / "cal" / "calibration.json").read_text())
    doc["sensors"]["accel"]["lever_arm_m"] = [0.06, -0.08]
    (d / "bad.json").write_text(json.dumps(doc))
    res = CliRunner().invoke(attitude, [str(d / "s"), "--calibration", str(d / "bad.json")])
    assert res.exit_code != 0
    assert "sensors.accel.lever_arm_m must be 3 finite numbers" in res.output
