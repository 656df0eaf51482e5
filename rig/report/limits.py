"""Acceptance limits of a calibration: a small schema and its evaluation.

Schema: `{sensor: {"<metric>_max": number, ...}, ...}`; each key bounds one metric of
`metrics.METRICS` from above, e.g.

    {"accel": {"residual_rms_max": 0.05, "norm_error_max": 0.02, "B_std_max": 3.0},
     "gyro":  {"move_error_deg_max": 0.5, "static_rate_dps_max": 0.05}}

A check PASSes when the metric is <= its limit. A metric that cannot be computed (no B_std from the
solver, no truth, sensor not calibrated) is UNAVAILABLE, which does not pass: a limit someone asked for
must never pass silently. Unknown sensors' limits are checked too (and are UNAVAILABLE); unknown
metric names are an error, since a typo would otherwise disable the check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rig.report.metrics import METRICS

PASS, FAIL, UNAVAILABLE = "PASS", "FAIL", "UNAVAILABLE"


class LimitsError(ValueError):
    """A limits dict breaks the schema; names the sensor and key."""


@dataclass(frozen=True)
class LimitCheck:
    sensor: str
    metric: str
    value: float
    limit: float
    result: str


def validate_limits(limits: dict) -> dict[str, dict[str, float]]:
    """The limits as {sensor: {metric: max}}; LimitsError on an unknown key or a non-number."""
    if not isinstance(limits, dict):
        raise LimitsError(f"limits must be a dict of sensor -> {{metric_max: value}}, got {type(limits).__name__}")
    out: dict[str, dict[str, float]] = {}
    for sensor, entries in limits.items():
        if not isinstance(entries, dict):
            raise LimitsError(f"limits[{sensor!r}] must be a dict of metric_max -> value")
        for key, value in entries.items():
            metric = key[:-4] if key.endswith("_max") else None
            if metric not in METRICS:
                known = ", ".join(f"{m}_max" for m in METRICS)
                raise LimitsError(f"limits[{sensor!r}][{key!r}]: unknown limit; known: {known}")
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise LimitsError(f"limits[{sensor!r}][{key!r}]: {value!r} is not a finite number")
            out.setdefault(sensor, {})[metric] = float(value)
    return out


def check_limits(values: dict[str, dict[str, float]], limits: dict) -> list[LimitCheck]:
    """One `LimitCheck` per limit, in the order given; `values` is {sensor: {metric: value}}."""
    checks = []
    for sensor, bounds in validate_limits(limits).items():
        for metric, limit in bounds.items():
            value = values.get(sensor, {}).get(metric, math.nan)
            if value is None or math.isnan(value):
                result = UNAVAILABLE
            else:
                result = PASS if value <= limit else FAIL
            checks.append(LimitCheck(sensor, metric, math.nan if value is None else value, limit, result))
    return checks


def verdict(checks: list[LimitCheck]) -> str:
    """PASS if every check passes, FAIL if any does not, NOT CHECKED without limits."""
    if not checks:
        return "NOT CHECKED"
    return PASS if all(c.result == PASS for c in checks) else FAIL
