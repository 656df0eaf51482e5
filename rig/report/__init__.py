"""Calibration and repeatability reports: Markdown with PNG figures (matplotlib, Agg canvas)."""

from rig.report.calibration_report import Evaluation, evaluate, write_report
from rig.report.limits import LimitCheck, LimitsError, check_limits, validate_limits, verdict
from rig.report.metrics import METRICS
from rig.report.repeatability import write_repeatability_report

__all__ = ["Evaluation", "evaluate", "METRICS", "LimitCheck", "LimitsError", "check_limits", "validate_limits", "verdict", "write_report",
           "write_repeatability_report"]
