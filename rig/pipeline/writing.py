"""The one writer of `calibration.json` for a calibrated session (`rig-calibration/1`, calibration-json.md).

A session run on the rig and a recorded session calibrated with `--from` end in the same file, with the
warnings and the excluded steps that say how it was made, and the table time the session used
(`table_time_s`: what a lab pays for, the figure the throughput planner works against).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rig.io.calibration_json import write_calibration
from rig.pipeline.result import SessionCalibration
from rig.session_data import SessionData

CALIBRATION_FILE = "calibration.json"


def table_time_s(session: SessionData) -> float | None:
    """Seconds of table time the session used: from the start of its first recorded move or hold to the end of
    its last hold, repeated holds and redone steps included (they lie in between on the session clock); the
    clock gaps left between the runs of a resumed session (`resumes` in its metadata) are not table time.
    None for a recording without a turntable, or one with no hold."""
    if session.meta.get("reference") == "none" or session.t.size == 0:
        return None
    holds = np.flatnonzero(~session.is_move)
    if holds.size == 0:
        return None
    span = float(np.max(session.t[holds]) - np.min(session.t))
    for mark in session.meta.get("resumes") or []:
        try:
            gap = float(mark["t_s"]) - float(mark["after_s"])
        except (KeyError, TypeError, ValueError):
            continue
        if np.isfinite(gap) and gap > 0:
            span -= gap
    return round(max(span, 0.0), 3)


def write_session_calibration(out_dir: str | os.PathLike, result: SessionCalibration, *, gravity: float,
                              field_uT: float | None, unit_serial: str | None = None, board: str | None = None,
                              extra: dict | None = None, session: SessionData | None = None) -> Path:
    """Write `out_dir/calibration.json` (folder made if needed) and return its path.

    `session`: the calibrated session, whose table time is recorded at the top level (`table_time_s`, null
    where the data had no turntable); without it (calibrated from files that are not a session) it is null.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / CALIBRATION_FILE
    keys = {**(extra or {}), "table_time_s": None if session is None else table_time_s(session),
            "warnings": result.warnings,
            "excluded_steps": {str(k): v for k, v in sorted(result.excluded_steps.items())},
            **({"not_calibrated": dict(result.refused)} if result.refused else {})}
    write_calibration(path, result.sensors, gravity=gravity, field_uT=field_uT, unit_serial=unit_serial,
                      board=board, extra=keys)
    return path
