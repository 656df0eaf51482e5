"""The calibration pipeline of a session: screening, solving, writing (see `run.py`)."""

from rig.pipeline.result import SessionCalibration, summary_lines
from rig.pipeline.run import calibrate_from_dir, calibrate_session
from rig.pipeline.solving import jackknife_std

__all__ = ["SessionCalibration", "calibrate_session", "calibrate_from_dir", "summary_lines", "jackknife_std"]
