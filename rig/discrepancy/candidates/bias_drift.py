"""The discrepancy analysis's tests of `bias_drift`: bias wander over the session."""

from __future__ import annotations

import numpy as np

from rig.discrepancy.candidates_base import AXES, Candidate, against_time, candidate_test, centred, per_axis
from rig.discrepancy.recording_base import pose_regressor
from rig.units import REPORT_UNITS


@candidate_test("bias_drift")
def bias_drift(sensor: str) -> Candidate:
    _, k = REPORT_UNITS[sensor]
    return Candidate(lambda o, f: per_axis(centred(o.t)), AXES, lambda c: float(np.abs(c).max() * 3600.0 / k),
                     lambda c: {"d_per_hour": (c * 3600.0 / k).tolist()}, against=against_time)


@pose_regressor("bias_drift", columns=lambda table: (table["t"] - table["t"].mean())[:, None] / 3600.0, rank=1)
def in_a_recordings_poses(c: np.ndarray, var: np.ndarray, resvar: np.ndarray) -> tuple[float, float, dict]:
    """The gyro's pose means (deg/s) against the pose's time (hours): d, deg/s per hour; dropped first when the
    poses are too few for every block."""
    return float(np.abs(c).max()), float(np.sqrt(var[0] * np.max(resvar))), {"d_deg_s_per_hour": c[0].tolist()}
