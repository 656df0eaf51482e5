"""Attitude of a recorded session against its reference: calibrate the raw counts, filter, compare.

Works on any session with a still interval first (phase 'hold') and motion after it: the first hold
initialises the filters (attitude, noise, reference dip) and fixes the constant rotation between the
filter's navigation frame and the reference's world frame; the statistics cover every row after it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.attitude.compare import Comparison, compare
from rig.attitude.noise import SensorNoise
from rig.attitude.peers import run_peer
from rig.attitude.timing import carried_forward, delayed, estimate_gyro_delay, estimate_vector_delay
from rig.attitude.ukf import AttitudeEstimate, UKFSettings, estimate_attitude
from rig.calibration.turntable.lever_arm import compensate
from rig.calibration.turntable.reference_convention import refuse_conjugated_reference
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.thermal.apply import apply_with_temperature
from rig.errors import CalibrationError
from rig.session_data import SessionData, filled

# The first second of the first hold is left to the filters to converge before the frames are aligned.
ALIGN_SKIP_S = 1.0
# A gap in the gyro's samples longer than this many of their median intervals is one the filter crosses blind.
GAP_INTERVALS = 10.0
REQUIRED = ("gyro", "accel")


@dataclass
class SessionRows:
    still: np.ndarray   # rows of the first hold
    align: np.ndarray   # its rows after ALIGN_SKIP_S
    evaluate: np.ndarray  # every row after the first hold


@dataclass
class Row:
    """One line of Table III: an estimator (filter + calibration) against the reference."""

    label: str
    filter: str
    calibration: str
    comparison: Comparison
    filter_summary: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"label": self.label, "filter": self.filter, "calibration": self.calibration,
                **self.comparison.to_dict(), "filter_summary": self.filter_summary}


def session_rows(session: SessionData, align_skip_s: float = ALIGN_SKIP_S) -> SessionRows:
    if session.meta.get("reference") == "none":
        raise CalibrationError(f"{session.source}: a recording without a turntable (reference \"none\") has no "
                               "reference orientation to validate an attitude filter against; rig attitude needs "
                               "a session whose table recorded its orientation")
    if "accel" in session.raw:
        refuse_conjugated_reference(session, session.holds("accel"))
    holds = session.hold_rows()
    if not holds:
        raise CalibrationError(f"{session.source}: no 'hold' rows; attitude validation needs a still interval first "
                               "to initialise the filter and align the frames")
    first = holds[0][1]
    if first[0] != 0 and session.is_move[: first[0]].any():
        raise CalibrationError(f"{session.source}: the session starts moving (row 0) before its first hold "
                               f"(row {int(first[0])}); attitude validation needs a still interval first")
    still = np.arange(first[0], first[-1] + 1)
    align = still[session.t[still] >= session.t[still[0]] + align_skip_s]
    if len(align) < 10:
        lasts = session.t[still[-1]] - session.t[still[0]]
        raise CalibrationError(f"{session.source}: the first hold lasts {lasts:.2f} s;"
                               f" at least {align_skip_s + 0.1:.1f} s is needed to align the frames")
    evaluate = np.arange(still[-1] + 1, len(session.t))
    if len(evaluate) < 10 or not session.is_move[evaluate].any():
        raise CalibrationError(f"{session.source}: no motion after the first hold; nothing to validate")
    return SessionRows(still, align, evaluate)


def gyro_gaps(session: SessionData, rows: SessionRows) -> list[tuple[float, float]]:
    """(time, seconds) of each gap in the gyro's samples over the evaluated rows longer than GAP_INTERVALS of their
    median interval: the filter predicts across it with the last rate, so whatever the table turned in the gap
    stays in the attitude after it (a session with a move recorded without samples: 12-19 deg RMS, said nowhere)."""
    have = rows.evaluate[~np.isnan(session.raw["gyro"][rows.evaluate]).any(axis=1)]
    t = session.t[np.r_[rows.still[-1], have]]
    if len(t) < 3:
        return []
    dt = np.diff(t)
    wide = np.flatnonzero(dt > GAP_INTERVALS * float(np.median(dt)))
    return [(float(t[i]), float(dt[i])) for i in wide]


class CalibratedSignals(dict):
    """sensor -> calibrated (n, 3) rows, remembering the lever arm (m) the accelerometer was compensated
    for (None: not compensated), so every filter's report can say so."""

    lever_arm_m: list[float] | None = None


def calibrated_signals(session: SessionData, sensors: dict[str, TriadCalibration]) -> CalibratedSignals:
    """`u = H (y - B)` per sensor, NaN rows kept; gyro and accel are required. A calibration with a temperature
    model applies at each row's die temperature, and refuses one outside its range (thermal/apply.py).

    When the accel calibration carries a significant lever arm (`rig.calibration.turntable.lever_arm`), the
    accelerometer is moved to the intersection of the table axes here, before any filter sees it: the
    centripetal and tangential terms of the moves are part of the calibration, not tilt, and our UKF and
    the ahrs peers all get the same compensated data.
    """
    missing = [s for s in REQUIRED if s not in session.raw or s not in sensors]
    if missing:
        have = f"session has {sorted(session.raw)}, calibration has {sorted(sensors)}"
        raise CalibrationError(f"{session.source}: attitude needs {', '.join(missing)} in both session and "
                               f"calibration ({have})")
    def calibrated(name: str, raw: np.ndarray, specific_force: np.ndarray | None = None) -> np.ndarray:
        return apply_with_temperature(name, sensors[name], raw, session.temp_c, specific_force)

    u = CalibratedSignals({name: calibrated(name, session.raw[name]) for name in session.raw if name in sensors})
    if sensors["gyro"].g_sensitivity is not None:            # a recording's calibration may carry one
        u["gyro"] = calibrated("gyro", session.raw["gyro"], calibrated("accel", filled(session.raw["accel"])))
    r = significant_lever_arm(sensors["accel"])
    if r is not None:
        u["accel"] = compensate(session.t, u["accel"], u["gyro"], r)
        u.lever_arm_m = [float(x) for x in r]
    return u


def significant_lever_arm(accel: TriadCalibration) -> np.ndarray | None:
    """The accelerometer's lever arm (m) when its calibration found one significant, else None."""
    if "lever_arm_m" not in accel.extra or not accel.extra.get("lever_arm_significant", False):
        return None
    value = accel.extra["lever_arm_m"]
    try:
        r = np.array(value, dtype=float)
    except (TypeError, ValueError):
        r = None
    if r is None or r.shape != (3,) or not np.isfinite(r).all():
        raise CalibrationError(f"calibration: sensors.accel.lever_arm_m must be 3 finite numbers (m), got {value!r}")
    return r


def aligned_signals(session: SessionData, sensors: dict[str, TriadCalibration],
                    rows: SessionRows) -> tuple[dict[str, np.ndarray], dict[str, float], SensorNoise]:
    """Calibrated signals with each sensor's latency against the reference removed (see `timing.py`),
    the latencies (s), and the sensor noise on the first hold (taken before the re-reading, which smooths it)."""
    u = calibrated_signals(session, sensors)
    st = rows.still
    noise = SensorNoise.from_static(u["gyro"][st], u["accel"][st], u["mag"][st] if "mag" in u else None)
    delays = {"gyro": estimate_gyro_delay(session.t, u["gyro"], session.q_ref, rows.evaluate)}
    u["gyro"] = delayed(session.t, u["gyro"], delays["gyro"])
    for name in ("accel", "mag"):
        if name in u:
            delays[name] = estimate_vector_delay(session.t, u[name], session.q_ref, st, rows.evaluate)
            u[name] = carried_forward(session.t, u[name], u["gyro"], delays[name])
    return u, delays, noise


def run_ukf(session: SessionData, u: dict[str, np.ndarray], rows: SessionRows, noise: SensorNoise | None = None,
            settings: UKFSettings | None = None) -> AttitudeEstimate:
    return estimate_attitude(session.t, u["gyro"], u["accel"], u.get("mag"), gravity=session.gravity,
                             field_uT=session.field_uT, noise=noise, still_rows=rows.still, settings=settings)


def ukf_row(session: SessionData, sensors: dict[str, TriadCalibration], calibration: str, rows: SessionRows,
            settings: UKFSettings | None = None) -> tuple[Row, AttitudeEstimate, tuple]:
    """The UKF's Table III row; also returns the estimate and the aligned inputs (for the peers)."""
    aligned = aligned_signals(session, sensors, rows)
    u, delays, noise = aligned
    est = run_ukf(session, u, rows, noise, settings)
    comp = compare(f"UKF, {calibration}", est.q, session.q_ref, rows.align, rows.evaluate)
    summary = {"latency_s": delays, "lever_arm_compensated_m": getattr(u, "lever_arm_m", None), **est.summary()}
    return Row(comp.name, "ukf", calibration, comp, summary), est, aligned


def peer_rows(session: SessionData, aligned: tuple, calibration: str, rows: SessionRows, est: AttitudeEstimate,
              peers: tuple[str, ...]) -> list[Row]:
    """The ahrs filters on the same calibrated data, noise and initial attitude as the UKF run `est`.

    They get the same latency-corrected (and, with a significant lever arm, compensated) signals. They
    integrate the rate of sample k over the interval (t_k-1, t_k] (rectangle rule), so their gyro is
    read at the interval's midpoint, half a period earlier, which is the most favourable reading for them.
    """
    u, delays, _ = aligned
    if "mag" not in u:
        return []
    half_period = 0.5 * float(np.median(np.diff(session.t)))
    gyro = delayed(session.t, u["gyro"], -half_period)
    out = []
    for name in peers:
        q = run_peer(name, session.t, gyro, u["accel"], u["mag"], noise=est.noise, gravity=session.gravity,
                     field_uT=est.field_uT, dip_deg=est.dip_deg, q0_enu=est.q[0], still=est.still)
        comp = compare(f"{name} (ahrs), {calibration}", q, session.q_ref, rows.align, rows.evaluate)
        summary = {"latency_s": delays, "gyro_read_shift_s": -half_period,
                   "lever_arm_compensated_m": getattr(u, "lever_arm_m", None)}
        out.append(Row(comp.name, name, calibration, comp, summary))
    return out
