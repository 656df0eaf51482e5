"""report.md says what was checked and why, and its metadata reads whole: nested keys one per row, lists
whole or counted, never JSON cut off mid-value; the packaged configuration checks each sensor's fit and how
well its B and H are known."""

from __future__ import annotations

import tomllib
from importlib import resources

import numpy as np
from report_tables import tables_by_heading
from synthetic_session import G, M, make_session, true_calibrations

from rig.calibration.numerics.result import TriadCalibration
from rig.report.calibration_report import write_report
from rig.report.limits import REASONS, validate_limits


def test_the_packaged_limits_check_each_sensors_fit_and_its_b_and_h_deviations():
    limits = validate_limits(tomllib.loads(resources.files("rig.configs").joinpath("sim.toml").read_text())["limits"])
    for sensor in ("accel", "gyro", "mag"):
        assert {"residual_rms", "B_std", "H_std_pct"} <= set(limits[sensor]), sensor


def test_an_uncertain_gain_fails_its_check_and_the_report_says_why(tmp_path):
    session = make_session()
    cals = true_calibrations()
    accel = cals["accel"]
    H_std = np.full((3, 3), 0.004) * np.abs(accel.H).max()          # 0.4 % of the gain: poorly determined
    cals["accel"] = TriadCalibration(B=accel.B, H=accel.H, B_std=np.full(3, 0.01), H_std=H_std, method="joint-ml",
                                     residual_rms=0.001)
    limits = {"accel": {"residual_rms_max": 0.05, "B_std_max": 0.1, "H_std_pct_max": 0.05}}
    text = write_report(tmp_path, session, cals, gravity=G, field_uT=M, limits=limits).read_text()
    rows = {r["check"]: r for r in tables_by_heading(text)["Acceptance"]}
    assert rows["H_std_pct_max"]["result"] == "FAIL" and rows["B_std_max"]["result"] == "PASS"
    assert rows["H_std_pct_max"]["why it is checked"] == REASONS["H_std_pct"]
    assert 0.3 < float(rows["H_std_pct_max"]["value"]) < 0.8
    assert "**Verdict: FAIL** (2 of 3 checks passed: residual_rms, B_std, H_std_pct of accel)" in text


def test_metadata_reads_whole_with_nested_keys_one_per_row(tmp_path):
    session = make_session()
    schedule = [{"outer_deg": float(a), "inner_deg": float(b)} for a, b in zip(range(0, 300, 10), range(30))]
    meta = {"unit": {"serial": "U-1", "board": "bsn"}, "schedule": schedule,
            "config": {"geometry": {"outer_axis_world": [1.0, 0.0, 0.0]}, "store": {"rig": "bench | 1"}},
            "chips": {"gyro": {"chip": "ITG-3200", "rate_hz": 100}}}
    text = write_report(tmp_path, session, true_calibrations(), gravity=G, field_uT=M, metadata=meta,
                        plots=False).read_text()
    rows = {r["key"]: r["value"] for r in tables_by_heading(text)["Metadata"]}
    assert rows["unit.serial"] == "U-1" and rows["chips.gyro.rate_hz"] == "100"
    assert rows["config.geometry.outer_axis_world"] == "[1, 0, 0]"
    assert rows["config.store.rig"] == "bench | 1"
    assert rows["schedule"].startswith("30 x (outer_deg, inner_deg): (0, 0), (10, 1),")
    assert rows["schedule"].endswith("... and 6 more")
    assert not any(v.endswith("...") for v in rows.values())
