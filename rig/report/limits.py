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

# why a limit on each metric is worth checking: what a value beyond it says about the calibration
REASONS = {
    "residual_rms": "the linear model u = H (y - B) must explain the data; a larger residual is an effect it "
                    "misses (a loose fixture, a field carried by the table, a hold that moved)",
    "norm_error_rms": "calibrated hold means must lie on the sphere of the known magnitude (G or M)",
    "norm_error": "no single orientation may miss the known magnitude by more (a bad hold, a saturated axis)",
    "rotation_residual_rms": "the hold means must turn with the table as its encoders say (axes or fixture "
                             "misaligned otherwise)",
    "rotation_residual": "no single orientation may disagree with the encoders by more",
    "B_std": "the offset must be known this well for use: the holds must constrain every axis (a blind axis or "
             "a noisy sensor leaves it uncertain)",
    "H_std": "the gain and misalignment must be known this well (in the sensor's own units)",
    "H_std_pct": "the gain and misalignment must be known to this fraction of the gain: the accuracy the unit "
                 "is calibrated for",
    "move_error_rms_deg": "the gyro's calibrated rates must integrate to the table's rotations",
    "move_error_deg": "no single move may integrate to a rotation further from the table's",
    "static_rate_dps": "the calibrated gyro must read no rotation while the table holds still (offset)",
    "H_error_pct": "simulated: the estimate must be this close to the simulator's truth",
    "B_error": "simulated: the offset must be this close to the simulator's truth",
}


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
