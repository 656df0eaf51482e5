"""The numbers a calibration report shows, computed from a session and its calibrations.

Static sensors (accel, mag) are checked against the session's known magnitude (G, M) and against the
reference rotations: with `u_j = H (y_j - B)` the calibrated hold mean at orientation j and `R_j` the
fixture -> world reference, the world vector is estimated as `v = mean_j R_j u_j` and the rotation
residual is `u_j - R_j^T v` (the consistency the two-step method's second step relies on, Zhang 2015).
The gyro is checked per move: the calibrated rates integrated over the move against the reference
rotation `R_j^T R_{j+1}` (conventions.md), error = angle of `R_ref^T R_int`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.calibration.numerics.integrate import integrate_rotation
from rig.calibration.numerics.result import TriadCalibration
from rig.session_data import SessionData
from rig.units import SENSOR_UNITS

STATIC_SENSORS = ("accel", "mag")


@dataclass
class StaticCheck:
    """Hold means of one static sensor against the sphere |u| = reference and the reference rotations."""

    reference: float
    steps: np.ndarray          # (k,)
    raw_means: np.ndarray      # (k, 3) counts
    calibrated: np.ndarray     # (k, 3) H (y - B)
    norm_error: np.ndarray     # (k,) |u_j| - reference
    world_vector: np.ndarray   # (3,) mean_j R_j u_j
    residual: np.ndarray       # (k, 3) u_j - R_j^T world_vector


@dataclass
class MoveCheck:
    """Integrated calibrated gyro rotation of every move against the reference rotation."""

    steps: np.ndarray          # (n,) orientation left
    duration_s: np.ndarray
    reference_deg: np.ndarray  # angle of R_ref
    integrated_deg: np.ndarray  # angle of R_int
    error_deg: np.ndarray      # angle of R_ref^T R_int


@dataclass
class SensorMetrics:
    sensor: str
    unit: str
    values: dict[str, float] = field(default_factory=dict)   # metric name -> value (NaN if unavailable)
    static: StaticCheck | None = None
    moves: MoveCheck | None = None
    static_rates_dps: np.ndarray | None = None               # gyro: |H (y_j - B)| at each hold, deg/s


# metric name -> (meaning, unit; "{unit}" is the sensor's calibrated unit)
METRICS = {
    "residual_rms": ("residual RMS reported by the calibration", "{unit}"),
    "norm_error_rms": ("RMS over holds of |H(y-B)| - reference", "{unit}"),
    "norm_error": ("max over holds of ||H(y-B)| - reference|", "{unit}"),
    "rotation_residual_rms": ("RMS over holds of |u_j - R_j^T v|", "{unit}"),
    "rotation_residual": ("max over holds of |u_j - R_j^T v|", "{unit}"),
    "B_std": ("largest standard deviation of an element of B", "counts"),
    "H_std": ("largest standard deviation of an element of H", "{unit}/count"),
    "H_std_pct": ("largest standard deviation of an element of H, in % of H's mean row norm", "%"),
    "move_error_rms_deg": ("RMS over moves of angle(R_ref^T R_int)", "deg"),
    "move_error_deg": ("max over moves of angle(R_ref^T R_int)", "deg"),
    "static_rate_dps": ("max over holds of |H(y-B)| of the gyro at rest", "deg/s"),
    "H_error_pct": ("|H - H_true|_F / |H_true|_F", "%"),
    "B_error": ("max over axes of |B - B_true|", "counts"),
}


def sensor_unit(sensor: str) -> str:
    return SENSOR_UNITS.get(sensor, "unit")


def sensor_metrics(session: SessionData, sensor: str, cal: TriadCalibration, *, gravity: float,
                   field_uT: float | None, truth: dict | None, settle_s: float) -> SensorMetrics:
    unit = sensor_unit(sensor)
    out = SensorMetrics(sensor, unit)
    v = out.values
    v["residual_rms"] = float(cal.residual_rms)
    v["B_std"] = _max_or_nan(cal.B_std)
    v["H_std"] = _max_or_nan(cal.H_std)
    v["H_std_pct"] = 100.0 * v["H_std"] / float(np.mean(np.linalg.norm(np.asarray(cal.H, dtype=float), axis=1)))
    reference = {"accel": gravity, "mag": field_uT}.get(sensor)
    if sensor in session.raw:
        if reference is not None:
            out.static = static_check(session, sensor, cal, reference, settle_s)
            if out.static.steps.size:
                v["norm_error_rms"] = _rms(out.static.norm_error)
                v["norm_error"] = float(np.max(np.abs(out.static.norm_error)))
                rnorm = np.linalg.norm(out.static.residual, axis=1)
                v["rotation_residual_rms"] = _rms(rnorm)
                v["rotation_residual"] = float(rnorm.max())
        if sensor == "gyro":
            out.moves = move_check(session, cal)
            if out.moves.steps.size:
                v["move_error_rms_deg"] = _rms(out.moves.error_deg)
                v["move_error_deg"] = float(out.moves.error_deg.max())
            holds = session.holds(sensor, settle_s)
            if holds.step.size:
                out.static_rates_dps = np.degrees(np.linalg.norm(cal.apply(holds.mean), axis=1))
                v["static_rate_dps"] = float(out.static_rates_dps.max())
    if truth is not None:
        v.update(truth_errors(cal, truth))
    return out


def static_check(session: SessionData, sensor: str, cal: TriadCalibration, reference: float,
                 settle_s: float) -> StaticCheck:
    holds = session.holds(sensor, settle_s)
    u = cal.apply(holds.mean)
    world = np.einsum("kab,kb->a", holds.R, u) / max(len(u), 1)
    residual = u - np.einsum("kba,b->ka", holds.R, world)
    return StaticCheck(reference, holds.step, holds.mean, u, np.linalg.norm(u, axis=1) - reference, world, residual)


def move_check(session: SessionData, cal: TriadCalibration) -> MoveCheck:
    rows = []
    for move in session.moves("gyro"):
        R_int = integrate_rotation(move.t, cal.apply(move.y))
        R_ref = move.known_rotation
        rows.append((move.step, move.t[-1] - move.t[0], rotation_angle_deg(R_ref), rotation_angle_deg(R_int),
                     rotation_angle_deg(R_ref.T @ R_int)))
    cols = np.array(rows, dtype=float).reshape(-1, 5).T
    return MoveCheck(cols[0].astype(int), *cols[1:])


def truth_errors(cal: TriadCalibration, truth: dict) -> dict[str, float]:
    H_true, B_true = np.asarray(truth["H"], dtype=float), np.asarray(truth["B"], dtype=float)
    return {"H_error_pct": float(100.0 * np.linalg.norm(cal.H - H_true) / np.linalg.norm(H_true)),
            "B_error": float(np.max(np.abs(cal.B - B_true)))}


def rotation_angle_deg(R: np.ndarray) -> float:
    """Angle of a rotation matrix, robust near 0 and 180 deg (atan2 of |skew| and trace)."""
    skew = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.degrees(np.arctan2(0.5 * np.linalg.norm(skew), 0.5 * (np.trace(R) - 1.0))))


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _max_or_nan(x) -> float:
    return float(np.max(x)) if x is not None and np.size(x) else float("nan")
