"""The calibration report: files written, and the numbers in its tables right (parsed back)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from report_tables import column, metric_values, tables_by_heading
from scipy.spatial.transform import Rotation
from synthetic_session import G, M, ORIENTATIONS, TRUE, make_session, true_calibrations, truth_dict

from rig.calibration.numerics.result import TriadCalibration
from rig.report.calibration_report import write_report
from rig.report.limits import LimitsError
from rig.rotations import TableGeometry

SCALE = 1.01
# moves about one fixed axis by less than half a turn: their angle scales with H
SINGLE_AXIS_MOVES = [j for j, ((a0, b0), (a1, b1)) in enumerate(zip(ORIENTATIONS, ORIENTATIONS[1:]))
                     if (a0 == a1 or b0 == b1) and abs(a1 - a0) + abs(b1 - b0) < 180]


@pytest.fixture(scope="module")
def session():
    return make_session()


@pytest.fixture(scope="module")
def perfect(session, tmp_path_factory):
    out = tmp_path_factory.mktemp("perfect")
    path = write_report(out, session, true_calibrations(), gravity=G, field_uT=M, truth=truth_dict())
    return out, path.read_text()


def _scaled(cal: TriadCalibration, scale: float = SCALE, dB=(0.0, 0.0, 0.0)) -> TriadCalibration:
    return TriadCalibration(B=cal.B + np.asarray(dB), H=scale * cal.H, method="perturbed", residual_rms=0.02)


def test_files_written_and_linked(perfect):
    out, text = perfect
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs == ["accel_ellipsoid.png", "accel_norms.png", "gyro_moves.png", "mag_ellipsoid.png", "mag_norms.png"]
    for name in pngs:
        assert f"]({name})" in text
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    assert json.loads((out / "report.json").read_text())["verdict"] == "NOT CHECKED"


def test_perfect_calibration_puts_hold_means_on_the_sphere(perfect):
    tables = tables_by_heading(perfect[1])
    accel, mag = tables["accel per orientation"], tables["mag per orientation"]
    assert [int(r["step"]) for r in accel] == list(range(len(ORIENTATIONS)))
    np.testing.assert_allclose(column(accel, "norm"), G, rtol=1e-7)
    np.testing.assert_allclose(column(mag, "norm"), M, rtol=1e-7)
    np.testing.assert_allclose(column(accel, "residual_z"), 0.0, atol=1e-9)


def test_parameter_table_lists_every_element_with_truth(perfect):
    rows = {r["parameter"]: r for r in tables_by_heading(perfect[1])["mag parameters"]}
    assert len(rows) == 12
    assert float(rows["H[1,2]"]["value"]) == pytest.approx(TRUE["mag"]["H"][1, 2], rel=1e-7)
    assert float(rows["B[2]"]["truth"]) == TRUE["mag"]["B"][2]
    assert rows["B[0]"]["std"] == "n/a"


def test_gyro_moves_against_reference_rotations(perfect):
    moves = tables_by_heading(perfect[1])["gyro per move"]
    geo = TableGeometry()
    expected = [np.degrees(Rotation.from_matrix(geo.rotation(*a).T @ geo.rotation(*b)).magnitude())
                for a, b in zip(ORIENTATIONS, ORIENTATIONS[1:])]
    np.testing.assert_allclose(column(moves, "reference_deg"), expected, rtol=1e-7)
    assert max(column(moves, "error_deg")) < 0.01      # 100 Hz samples of a smooth 2 s move


def test_scaled_H_shows_in_norms_moves_and_truth_errors(session, perfect, tmp_path):
    cals = true_calibrations()
    cals = {"accel": _scaled(cals["accel"]), "gyro": _scaled(cals["gyro"]), "mag": _scaled(cals["mag"], 1.0, (2.0, 0, -1.0))}
    tables = tables_by_heading(write_report(tmp_path, session, cals, gravity=G, field_uT=M, truth=truth_dict()).read_text())
    base = tables_by_heading(perfect[1])

    np.testing.assert_allclose(column(tables["accel per orientation"], "norm_error"), (SCALE - 1) * G, rtol=1e-6)
    quality = metric_values(tables["accel fit quality"])
    assert quality["H_error_pct"] == pytest.approx(100 * (SCALE - 1), rel=1e-6)
    assert quality["norm_error"] == pytest.approx((SCALE - 1) * G, rel=1e-6)
    assert quality["residual_rms"] == 0.02
    assert metric_values(tables["mag fit quality"])["B_error"] == 2.0
    mag_params = {r["parameter"]: float(r["error"]) for r in tables["mag parameters"]}
    assert (mag_params["B[0]"], mag_params["B[2]"]) == (2.0, -1.0)
    # a move about one fixed axis integrates to SCALE times the angle
    scaled = column(tables["gyro per move"], "integrated_deg")
    plain = column(base["gyro per move"], "integrated_deg")
    np.testing.assert_allclose([scaled[j] for j in SINGLE_AXIS_MOVES], [SCALE * plain[j] for j in SINGLE_AXIS_MOVES],
                               rtol=1e-6)


def test_gyro_bias_error_shows_as_rate_at_rest(session, tmp_path):
    cal = true_calibrations()["gyro"]
    wrong = TriadCalibration(B=cal.B + [10.0, 0.0, 0.0], H=cal.H, method="biased")
    tables = tables_by_heading(write_report(tmp_path, session, {"gyro": wrong}, gravity=G, field_uT=M).read_text())
    quality = metric_values(tables["gyro fit quality"])
    assert quality["static_rate_dps"] == pytest.approx(np.degrees(np.linalg.norm(cal.H @ [10.0, 0, 0])), rel=1e-6)


def test_misrotated_H_keeps_norms_but_not_rotation_residual(session, tmp_path):
    cal = true_calibrations()["accel"]
    turned = TriadCalibration(B=cal.B, H=Rotation.from_euler("z", 2.0, degrees=True).as_matrix() @ cal.H, method="x")
    tables = tables_by_heading(write_report(tmp_path, session, {"accel": turned}, gravity=G, field_uT=M).read_text())
    quality = metric_values(tables["accel fit quality"])
    assert quality["norm_error"] < 1e-9
    assert quality["rotation_residual"] > 0.1        # 2 deg of G is 0.34 m/s^2 where the turn is seen


@pytest.mark.parametrize("limit, result", [(1.001 * (SCALE - 1) * G, "PASS"), (0.999 * (SCALE - 1) * G, "FAIL")])
def test_pass_fail_flips_at_the_limit(session, tmp_path, limit, result):
    cals = {"accel": _scaled(true_calibrations()["accel"])}
    limits = {"accel": {"norm_error_max": limit, "residual_rms_max": 0.05}}
    text = write_report(tmp_path, session, cals, gravity=G, field_uT=M, limits=limits).read_text()
    checks = {r["check"]: r for r in tables_by_heading(text)["Acceptance"]}
    assert checks["norm_error_max"]["result"] == result
    assert float(checks["norm_error_max"]["value"]) == pytest.approx((SCALE - 1) * G, rel=1e-6)
    assert checks["residual_rms_max"]["result"] == "PASS"
    assert f"**Verdict: {result}**" in text
    assert json.loads((tmp_path / "report.json").read_text())["verdict"] == result


def test_a_limit_that_cannot_be_evaluated_does_not_pass(session, tmp_path):
    cal = true_calibrations()["accel"]
    limits = {"accel": {"B_std_max": 1.0}, "mag": {"norm_error_max": 1.0}}
    text = write_report(tmp_path, session, {"accel": cal}, gravity=G, field_uT=M, limits=limits).read_text()
    assert [r["result"] for r in tables_by_heading(text)["Acceptance"]] == ["UNAVAILABLE", "UNAVAILABLE"]
    assert "**Verdict: FAIL**" in text

    cal.B_std = np.array([0.2, 0.7, 0.4])
    text = write_report(tmp_path, session, {"accel": cal}, gravity=G, field_uT=M, limits={"accel": {"B_std_max": 1.0}}).read_text()
    (row,) = tables_by_heading(text)["Acceptance"]
    assert (float(row["value"]), row["result"]) == (0.7, "PASS")


def test_unknown_limit_is_refused_before_anything_is_written(session, tmp_path):
    with pytest.raises(LimitsError, match=r"limits\['accel'\]\['norm_err_max'\]: unknown limit"):
        write_report(tmp_path / "r", session, true_calibrations(), gravity=G, field_uT=M,
                     limits={"accel": {"norm_err_max": 0.1}})
    assert not (tmp_path / "r").exists()


def test_malformed_truth_names_the_sensor(session, tmp_path):
    with pytest.raises(ValueError, match=r"truth\['sensors'\]\['gyro'\]"):
        write_report(tmp_path, session, true_calibrations(), gravity=G, field_uT=M,
                     truth={"sensors": {"gyro": {"B": [1, 2], "H": np.eye(3).tolist()}}})


def test_session_and_metadata_summary(perfect):
    tables = tables_by_heading(perfect[1])
    facts = {r["item"]: r["value"] for r in tables["Session"]}
    assert (facts["holds"], facts["moves"], facts["G_mps2"], facts["M_uT"]) == ("12", "11", "9.80665", "48")
    meta = {r["key"]: r["value"] for r in tables["Metadata"]}
    assert meta == {"unit_serial": "SIM-7", "operator": "test | pipe"}
