"""What a session's page shows besides its rows: its calibrations with their units, each judged by its limits,
the residual of every orientation, and every file of the session to download.

Units follow the calibration file (calibration-json.md): a sensor reads `u = H (y - B)` in its unit (m/s^2, rad/s,
uT), so B is in counts and H in that unit per count. The limits' metrics carry the units of `rig.report.metrics`.
"""

from __future__ import annotations

import json
import math

import numpy as np

from rig.io.calibration_json import triads_from_calibration
from rig.lab.records import CalibrationRecord
from rig.report.calibration_report import evaluate, metric_unit
from rig.report.metrics import METRICS
from rig.units import SENSOR_UNITS

CALIBRATION_NAME = "calibration.json"
REPORT_SUMMARY = "report.json"
SESSION_NAME = "session.sqlite"


def calibration_file_name(record: CalibrationRecord) -> str:
    """The name a calibration is downloaded under: the rig's own as the session folder holds it, a batch run's
    as the folder store keeps it (`lab/calibration-<run>.json`)."""
    return CALIBRATION_NAME if record.run is None else f"calibration-{record.run}.json"


def sensor_rows(record: CalibrationRecord) -> list[dict]:
    """Per sensor: its unit, B (counts) and H (unit per count) with their standard deviations."""
    rows = []
    for name, cal in record.sensors().items():
        unit = str(cal.get("unit") or SENSOR_UNITS.get(name, "unit"))
        rows.append({"sensor": name, "unit": unit, "B_unit": "counts", "H_unit": f"{unit} per count",
                     "B": cal.get("B") or [], "B_std": cal.get("B_std") or [], "H": cal.get("H") or [],
                     "H_std": cal.get("H_std") or []})
    return rows


def check_rows(checks: list, units: dict[str, str]) -> list[dict]:
    """The limits' checks (`rig.report.limits.LimitCheck` as dicts: sensor, metric, value, limit, result) with
    the unit of each metric for its sensor."""
    rows = []
    for check in checks or []:
        if not isinstance(check, dict):
            continue
        metric, sensor = str(check.get("metric", "")), str(check.get("sensor", ""))
        known = metric in METRICS
        unit = metric_unit(metric, sensor, units.get(sensor, SENSOR_UNITS.get(sensor, "unit"))) if known else ""
        rows.append({"sensor": sensor, "check": f"{metric}_max", "value": check.get("value"),
                     "limit": check.get("limit"), "result": check.get("result"),
                     "meaning": METRICS[metric][0] if known else "", "unit": unit})
    return rows


def report_checks(store, key: str) -> list | None:
    """The checks the rig's own report judged its calibration by (`report.json`), None without that file."""
    found = store.artifact(key, REPORT_SUMMARY)
    if found is None:
        return None
    try:
        summary = json.loads(found[1])
    except ValueError:
        return None
    checks = summary.get("checks") if isinstance(summary, dict) else None
    return checks if isinstance(checks, list) else None


def residuals(session, document: dict) -> dict:
    """The calibrated session judged orientation by orientation, as its report does (`rig.report.metrics`): per
    static sensor the residual `u_j - R_j^T v` and the norm error `|u_j| - reference` of every hold, in its unit;
    for the gyroscope the angle between the reference and the integrated rotation of every move, in deg."""
    cals = triads_from_calibration(document)
    gravity = float(document.get("gravity_mps2") or session.gravity)
    field = document.get("field_uT", session.field_uT)
    evaluation = evaluate(session, cals, gravity=gravity, field_uT=field)
    out = {}
    for name, m in evaluation.metrics.items():
        entry: dict = {"unit": m.unit}
        if m.static is not None and m.static.steps.size:
            entry.update(steps=m.static.steps.tolist(), residual=_finite(m.static.residual),
                         norm_error=_finite(m.static.norm_error), reference=m.static.reference)
        if m.moves is not None and m.moves.steps.size:
            entry.update(moves=m.moves.steps.tolist(), move_error_deg=_finite(m.moves.error_deg))
        if len(entry) > 1:
            out[name] = entry
    return {"sensors": out}


def _finite(values: np.ndarray) -> list:
    return [_finite(v) if isinstance(v, np.ndarray) else (float(v) if math.isfinite(v) else None)
            for v in np.asarray(values, dtype=float)]
