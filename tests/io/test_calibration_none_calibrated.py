"""A recording none of whose sensors could be calibrated: calibration.json still says why of each
(`not_calibrated`), and reading it back to apply it is refused naming those reasons, not a missing key."""

from __future__ import annotations

import json

import pytest

from rig.io.calibration_json import CalibrationFileError, read_calibration, write_calibration

WHY = {"accel": "its poses lie in two orientations", "mag": "the samples do not bound an ellipsoid"}


def test_a_file_with_no_sensor_says_why_and_is_refused_for_applying(tmp_path):
    path = write_calibration(tmp_path / "calibration.json", {}, gravity=9.81, field_uT=None,
                             extra={"not_calibrated": WHY})
    doc = json.loads(path.read_text())
    assert doc["sensors"] == {} and doc["not_calibrated"] == WHY
    with pytest.raises(CalibrationFileError) as refused:
        read_calibration(path)
    assert all(why in str(refused.value) for why in WHY.values()), str(refused.value)


def test_no_sensor_and_no_reason_is_not_written(tmp_path):
    with pytest.raises(ValueError, match="no sensors to write"):
        write_calibration(tmp_path / "calibration.json", {}, gravity=9.81, field_uT=None)
    assert not (tmp_path / "calibration.json").exists()
