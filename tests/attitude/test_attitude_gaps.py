"""`rig attitude` says where the gyro has no samples: the filters cross a gap on the last rate, and what the table
turned there stays in every attitude after it."""

from __future__ import annotations

import json

import numpy as np
from click.testing import CliRunner

from rig.calibration.numerics.result import TriadCalibration
from rig.commands.attitude import attitude
from rig.io.calibration_json import write_calibration
from rig.io.session_writer import write_session
from tests.io.io_synthetic import build_session


def _run(tmp_path, session, truth) -> tuple[str, dict]:
    folder = write_session(session, tmp_path / "s")
    cal = write_calibration(tmp_path / "cal.json", {n: TriadCalibration(B=truth.B[n], H=truth.H[n], method="truth")
                                                    for n in session.raw}, gravity=session.gravity,
                            field_uT=session.field_uT)
    done = CliRunner().invoke(attitude, [str(folder), "--calibration", str(cal), "--no-peers", "--json",
                                         str(tmp_path / "a.json")])
    assert done.exit_code == 0, done.output
    return done.output, json.loads((tmp_path / "a.json").read_text())


def test_a_move_without_gyro_samples_is_named_and_a_whole_one_is_not(tmp_path):
    session, truth = build_session(seed=3, hold_s=2.0)
    out, doc = _run(tmp_path / "whole", session, truth)
    assert "no samples" not in out and doc["gyro_gaps"] == []

    moving = np.flatnonzero(session.is_move)
    second = moving[np.flatnonzero(np.diff(moving) > 1)[0] + 1]       # the first row of the second move
    lost = np.arange(second, second + 60)
    assert session.is_move[lost].all()
    session.raw["gyro"][lost] = np.nan
    out, doc = _run(tmp_path / "gap", session, truth)
    assert len(doc["gyro_gaps"]) == 1, doc["gyro_gaps"]
    gap = doc["gyro_gaps"][0]
    assert abs(gap["seconds"] - (session.t[lost[-1] + 1] - session.t[lost[0] - 1])) < 1e-9
    assert f"no samples for {gap['seconds']:.2f} s from t = {gap['t_s']:.2f} s" in out
