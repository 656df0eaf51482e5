"""The twin's calibration of a still log: one pose held for its whole length (an Allan-variance run, a unit left on
the bench), which no calibration can be fitted to, and whose noise the twin compares all the same.

There is nothing to fit: the replicas need only a response that gives the log's own mean back, and every statistic
of the twin is taken in the recording's units. The pose's gravity (the accelerometer) and field (the magnetometer)
keep the norm of the environment at the log's mean direction (`H` a scalar, `B` zero: the nominal scale the mean's
norm gives); the gyroscope is at rest (`B` the log's mean) with the scale its unit names. A magnitude the twin names
is reported in the vocabulary's unit through that scale, and where none is known (a gyroscope or magnetometer in
counts) in counts (`REPORT_UNIT_KEY`).
"""

from __future__ import annotations

import numpy as np

from rig.calibration.recordings.recording import RecordingCalibration
from rig.calibration.recordings.recording_checks import check_no_stuck_axis
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.recordings.segments import DEFAULT_TILT_SD_DEG, Pose
from rig.errors import CalibrationError
from rig.noise.still import moving_axis
from rig.session_data import SessionData
from rig.units import DEG

METHOD = "still log: the recording's own mean, no calibration"
REPORT_UNIT_KEY = "report_unit"       # in `extra`: the unit a magnitude is reported in where no scale is known
GYRO_PER_RAW = {"deg/s": DEG, "rad/s": 1.0}
MIN_SAMPLES = 8                       # the least an Allan deviation is taken of (`rig.noise.allan`)


def is_still_log(session: SessionData) -> bool:
    """One pose held for the whole recording, with no segment saying otherwise."""
    return not session.meta.get("segments") and moving_axis(session) is None


def is_still_log_calibration(rec: RecordingCalibration) -> bool:
    return bool(rec.sensors) and all(cal.method == METHOD for cal in rec.sensors.values())


def still_log_calibration(session: SessionData) -> RecordingCalibration:
    """One pose over every row, and each sensor's response that gives its mean back (module docstring), for a
    recording `is_still_log` found still; every replica of it is calibrated so too, without asking again."""
    check_no_stuck_axis(session)
    if len(session.t) < MIN_SAMPLES:
        raise CalibrationError(f"{session.source}: a still log of {len(session.t)} samples; its twin needs at least "
                               f"{MIN_SAMPLES} (an Allan deviation)")
    units = session.meta.get("units", {})
    sensors = {}
    for name, y in session.raw.items():
        mean = np.nanmean(y, axis=0)
        unit = units.get(name, "counts")
        if name == "gyro":
            per_raw = GYRO_PER_RAW.get(unit, DEG)         # counts: one count reported as one "count" (below)
            sensors[name] = TriadCalibration(mean, per_raw * np.eye(3), METHOD)
        else:
            norm = session.gravity if name == "accel" else session.field_uT
            sensors[name] = TriadCalibration(np.zeros(3), (norm or np.linalg.norm(mean)) / np.linalg.norm(mean)
                                             * np.eye(3), METHOD)
        if (name == "gyro" and unit not in GYRO_PER_RAW) or (name == "mag" and not session.field_uT
                                                               and unit == "counts"):
            sensors[name].extra[REPORT_UNIT_KEY] = "counts"
    pose = Pose("log", np.arange(len(session.t)), None, DEFAULT_TILT_SD_DEG)
    return RecordingCalibration(sensors, [pose], [], [])
