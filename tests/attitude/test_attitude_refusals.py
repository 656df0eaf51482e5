"""The attitude comparison refuses, with a reason, what it cannot evaluate."""

import pytest

from procedures.validation import validate_session
from rig.calibration.numerics.result import TriadCalibration
from rig.errors import CalibrationError
from tests.io.io_synthetic import build_session


def test_a_session_without_accelerometer_is_refused_by_name():
    session, truth = build_session(seed=4, hold_s=2.0, sensors=("gyro",))
    ours = {"gyro": TriadCalibration(B=truth.B["gyro"], H=truth.H["gyro"], method="truth")}
    with pytest.raises(CalibrationError, match="cannot be evaluated: .*attitude needs accel"):
        validate_session(session, {"ours": ours}, peers=())
