"""The one writer of `calibration.json` for a calibrated session (`rig-calibration/1`, calibration-json.md).

A session run on the rig and a recorded session calibrated with `--from` end in the same file, with the
warnings and the excluded steps that say how it was made.
"""

from __future__ import annotations

import os
from pathlib import Path

from rig.io.calibration_json import write_calibration
from rig.pipeline.result import SessionCalibration

CALIBRATION_FILE = "calibration.json"


def write_session_calibration(out_dir: str | os.PathLike, result: SessionCalibration, *, gravity: float,
                              field_uT: float | None, unit_serial: str | None = None, board: str | None = None,
                              extra: dict | None = None) -> Path:
    """Write `out_dir/calibration.json` (folder made if needed) and return its path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / CALIBRATION_FILE
    keys = {**(extra or {}), "warnings": result.warnings,
            "excluded_steps": {str(k): v for k, v in sorted(result.excluded_steps.items())}}
    write_calibration(path, result.sensors, gravity=gravity, field_uT=field_uT, unit_serial=unit_serial,
                      board=board, extra=keys)
    return path
