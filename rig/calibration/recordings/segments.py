"""The pieces a recording's segments name (session-csv.md, "Recordings without a turntable"): static poses, with
the axis that was up and how far a hand may have tilted it, and turns of known angle about a sensor axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.calibration.recordings.recording_fits import AXIS_VECTORS
from rig.session_data import SessionData

DEFAULT_TILT_SD_DEG = 2.0
DEFAULT_TURN_SD_DEG = 2.0


@dataclass
class Pose:
    name: str
    rows: np.ndarray          # indices of the pose's samples
    up: str | None
    tilt_sd_deg: float


@dataclass
class Turn:
    name: str
    rows: np.ndarray
    axis: np.ndarray          # nominal unit axis, sensor frame
    angle_rad: float
    angle_sd_rad: float
    axis_sd_rad: float


def segments_of(session: SessionData) -> tuple[list[Pose], list[Turn]]:
    """The static poses and turns the session's segments name, in time order."""
    poses, turns = [], []
    tilts = [s.get("tilt_deg_sd", DEFAULT_TILT_SD_DEG) for s in session.meta.get("segments") or []
             if s["kind"] == "static"]
    axis_sd = np.radians(max(tilts) if tilts else DEFAULT_TILT_SD_DEG)
    for seg in session.meta.get("segments") or []:
        rows = np.flatnonzero((session.t >= seg["t0"]) & (session.t <= seg["t1"]))
        if rows.size < 2:
            continue
        if seg["kind"] == "static":
            poses.append(Pose(seg["name"], rows, seg.get("up"), float(seg.get("tilt_deg_sd", DEFAULT_TILT_SD_DEG))))
        else:
            turns.append(Turn(seg["name"], rows, np.array(AXIS_VECTORS[seg["axis"]], dtype=float),
                              float(np.radians(seg["angle_deg"])),
                              float(np.radians(seg.get("angle_deg_sd", DEFAULT_TURN_SD_DEG))), float(axis_sd)))
    return poses, turns
