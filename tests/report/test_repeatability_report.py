"""The repeatability report: per-element mean and spread over runs, read back from its table."""

from __future__ import annotations

import json

import numpy as np
import pytest
from report_tables import column, tables_by_heading
from synthetic_session import TRUE, truth_dict

from rig.calibration.numerics.result import TriadCalibration
from rig.report.repeatability import write_repeatability_report

B_NOISE = {"accel": 2.0, "gyro": 0.5, "mag": 4.0}
H_NOISE_REL = 1e-3


def _runs(n: int, seed: int, sensors=("accel", "gyro", "mag")) -> list[dict[str, TriadCalibration]]:
    rng = np.random.default_rng(seed)
    runs = []
    for _ in range(n):
        run = {}
        for s in sensors:
            B = TRUE[s]["B"] + rng.normal(0.0, B_NOISE[s], 3)
            H = TRUE[s]["H"] + rng.normal(0.0, H_NOISE_REL * np.abs(TRUE[s]["H"]).max(), (3, 3))
            run[s] = TriadCalibration(B=B, H=H, method="two-step")
        runs.append(run)
    return runs


def test_table_gives_mean_std_and_truth_error_of_every_element(tmp_path):
    runs = _runs(6, seed=3)
    path = write_repeatability_report(tmp_path, runs, truth=truth_dict())
    rows = tables_by_heading(path.read_text())["gyro [B in counts, H in rad/s/count]"]
    values = np.array([np.concatenate([r["gyro"].B, r["gyro"].H.ravel()]) for r in runs])
    assert [r["element"] for r in rows][:4] == ["B[0]", "B[1]", "B[2]", "H[0,0]"]
    np.testing.assert_allclose(column(rows, "mean"), values.mean(axis=0), rtol=1e-7)
    np.testing.assert_allclose(column(rows, "std"), values.std(axis=0, ddof=1), rtol=1e-7)
    by_element = {r["element"]: r for r in rows}
    assert float(by_element["H[1,2]"]["truth"]) == TRUE["gyro"]["H"][1, 2]
    assert float(by_element["H[1,2]"]["mean"]) == pytest.approx(np.mean([r["gyro"].H[1, 2] for r in runs]), rel=1e-7)
    np.testing.assert_allclose(column(rows, "mean_error"), values.mean(axis=0) - np.concatenate(
        [TRUE["gyro"]["B"], TRUE["gyro"]["H"].ravel()]), rtol=1e-6, atol=1e-12)
    for s in ("accel", "gyro", "mag"):
        assert (tmp_path / f"repeatability_{s}.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((tmp_path / "repeatability.json").read_text())["sensors"]["mag"]["runs"] == 6


def test_spread_recovers_the_run_to_run_noise(tmp_path):
    text = write_repeatability_report(tmp_path, _runs(300, seed=11, sensors=("mag",))).read_text()
    rows = tables_by_heading(text)["mag [B in counts, H in uT/count]"]
    np.testing.assert_allclose(column(rows, "std")[:3], B_NOISE["mag"], rtol=0.12)
    assert all(r["truth"] == "n/a" for r in rows)


def test_sensor_missing_from_some_runs_counts_only_its_runs(tmp_path):
    runs = _runs(4, seed=5, sensors=("accel",)) + _runs(3, seed=6, sensors=("accel", "mag"))
    tables = tables_by_heading(write_repeatability_report(tmp_path, runs).read_text())
    assert {r["runs"] for r in tables["mag [B in counts, H in uT/count]"]} == {"3"}
    assert {r["runs"] for r in tables["accel [B in counts, H in m/s^2/count]"]} == {"7"}


def test_no_runs_is_an_error(tmp_path):
    with pytest.raises(ValueError, match="no runs"):
        write_repeatability_report(tmp_path, [])
