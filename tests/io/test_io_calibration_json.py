"""The calibration file: schema round trip, strict JSON, and validation errors naming file and key."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from rig.calibration.numerics.result import TriadCalibration
from rig.io.calibration_json import CalibrationFileError, read_calibration, triads_from_calibration, write_calibration


def triad(seed: int, method: str = "two-step") -> TriadCalibration:
    rng = np.random.default_rng(seed)
    H = np.diag([6e-4, 5.9e-4, 6.1e-4]) @ (np.eye(3) + 0.01 * rng.standard_normal((3, 3)))
    return TriadCalibration(B=rng.normal(0, 100, 3), H=H, method=method, residual_rms=1.3e-3, iterations=9,
                            B_std=np.array([0.1, 0.2, 0.3]), H_std=np.full((3, 3), 1e-7),
                            extra={"reference_world": np.array([0.0, 0.1, 9.8]), "norm_rms": np.float64(2e-4)})


@pytest.fixture
def written(tmp_path) -> Path:
    sensors = {"accel": triad(1), "gyro": triad(2, "gyro-ukf"), "mag": triad(3)}
    sensors["gyro"].residual_rms = float("nan")
    sensors["gyro"].B_std = None
    return write_calibration(tmp_path / "out" / "calibration.json", sensors, gravity=9.81, field_uT=48.0,
                             unit_serial="BSN-0042", board="bsn", extra={"source": {"path": "/x"}})


def test_schema_fields(written):
    doc = json.loads(written.read_text())
    assert doc["schema"] == "rig-calibration/1"
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", doc["created"])
    assert doc["software"] == "rig 0.1.0"
    assert doc["unit"] == {"serial": "BSN-0042", "board": "bsn"}
    assert (doc["gravity_mps2"], doc["field_uT"]) == (9.81, 48.0)
    assert {k: v["unit"] for k, v in doc["sensors"].items()} == {"accel": "m/s^2", "gyro": "rad/s", "mag": "uT"}
    acc = doc["sensors"]["accel"]
    for key in ("B", "H", "B_std", "H_std", "residual_rms", "method", "iterations"):
        assert key in acc
    assert acc["reference_world"] == [0.0, 0.1, 9.8] and acc["norm_rms"] == 2e-4
    assert doc["source"] == {"path": "/x"}


def test_strict_json_unknown_numbers_left_out(written):
    text = written.read_text()
    assert "NaN" not in text
    json.loads(text, parse_constant=lambda c: pytest.fail(f"non-standard constant {c}"))
    gyro = json.loads(text)["sensors"]["gyro"]
    assert "residual_rms" not in gyro and "B_std" not in gyro and "H_std" in gyro


def test_round_trip_values(written):
    doc = read_calibration(written)
    back = triads_from_calibration(doc)
    ref = triad(1)
    np.testing.assert_array_equal(back["accel"].H, ref.H)
    np.testing.assert_array_equal(back["accel"].B, ref.B)
    np.testing.assert_array_equal(back["accel"].B_std, ref.B_std)
    assert back["gyro"].method == "gyro-ukf" and np.isnan(back["gyro"].residual_rms)
    y = np.array([[100.0, 200.0, 300.0]])
    np.testing.assert_allclose(back["mag"].apply(y), triad(3).apply(y), rtol=1e-15)


def test_atomic_write_leaves_no_temp_files(written):
    assert sorted(p.name for p in written.parent.iterdir()) == ["calibration.json"]


def test_write_refuses_negative_det_and_clashing_extra(tmp_path):
    bad = triad(1)
    bad.H = -bad.H
    with pytest.raises(ValueError, match="det"):
        write_calibration(tmp_path / "c.json", {"accel": bad}, gravity=9.8, field_uT=None)
    with pytest.raises(ValueError, match="schema"):
        write_calibration(tmp_path / "c.json", {"accel": triad(1)}, gravity=9.8, field_uT=None,
                          extra={"schema": "x"})
    assert not (tmp_path / "c.json").exists()


def rewrite(path: Path, change) -> None:
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))


@pytest.mark.parametrize("change, key, words", [
    (lambda d: d.__setitem__("schema", "rig-calibration/2"), "schema", "must be 'rig-calibration/1'"),
    (lambda d: d["sensors"]["accel"].pop("H"), "sensors.accel.H", "required field missing"),
    (lambda d: d["sensors"]["mag"].pop("unit"), "sensors.mag.unit", "required field missing"),
    (lambda d: d["sensors"]["gyro"].__setitem__("B", [1, 2]), "sensors.gyro.B", "3-vector"),
    (lambda d: d["sensors"]["accel"].__setitem__("H", [[1, 0, 0], [0, 1, 0], [0, 0, -1]]), "sensors.accel.H",
     "det(H) = -1"),
    (lambda d: d["sensors"]["accel"].__setitem__("H", [[1, 0, 0], [0, "a", 0], [0, 0, 1]]), "sensors.accel.H",
     "3x3 matrix"),
    (lambda d: d["sensors"]["accel"].__setitem__("B_std", [0, -1, 0]), "sensors.accel.B_std", "negative"),
    (lambda d: d.__setitem__("sensors", {}), "sensors", "at least one"),
    (lambda d: d.__setitem__("gravity_mps2", -9.8), "gravity_mps2", "positive"),
])
def test_validation_errors_name_file_and_key(written, change, key, words):
    rewrite(written, change)
    with pytest.raises(CalibrationFileError) as info:
        read_calibration(written)
    assert (info.value.key, Path(info.value.file).name) == (key, "calibration.json")
    assert words in str(info.value)


def test_invalid_json_and_missing_file(tmp_path):
    p = tmp_path / "c.json"
    p.write_text('{"schema": "rig-calibration/1",\n "sensors": }')
    with pytest.raises(CalibrationFileError, match="line 2"):
        read_calibration(p)
    with pytest.raises(CalibrationFileError, match="no such file"):
        read_calibration(tmp_path / "none.json")


def test_nan_literal_in_matrix_rejected(written):
    rewrite(written, lambda d: d["sensors"]["accel"].__setitem__("B", [float("nan"), 0.0, 0.0]))
    with pytest.raises(CalibrationFileError, match="non-finite") as info:
        read_calibration(written)
    assert info.value.key == "sensors.accel.B"
