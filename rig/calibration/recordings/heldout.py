"""What a recording's calibration predicts for data left out of its fit: with no truth, the only fair
score of ours against a peer's on the peer's own data.

* Accelerometer, leave one pose out: refit without pose i, then the norm error `|a| - g` of the calibrated
  samples of pose i (RMS over its samples, and the error of its mean).
* Gyroscope, leave one turn out: refit without turn k, then the angle its calibrated rate sums to about the
  nominal axis against the known angle (Ferraris: 360 deg).
* Gyroscope, leave one motion out (imu_tk's criterion): refit without the motion between poses i and i+1, then
  the angle between pose i's gravity direction carried across it by the calibrated gyro and pose i+1's.
* Rests no segment names (a hand puts the unit down again before and after a turn, `rig.calibration.recordings.rests`):
  the norm error there, and the gravity carried across the motions into and out of them, are held out for any
  calibration fitted on the segments, so they score a peer that cannot refit without a face or a turn.

A refit that leaves out a turn or motion starts its gyro fit at the fit on everything (`gyro_start`) rather than
at its own coarse search: the same optimum, the left-out angles within 2.2e-6 deg on the Xsens and 4e-7 deg on
imucal's SI file. It keeps the accelerometer's fit on everything (`accel`), which never sees a turn or motion. The
Xsens's held-out scores (37 motions) take 5.4 CPU-s where they took 12.1; its twin runs them twice.

Every score is computed from calibrated series (m/s^2, rad/s) on the rows of the poses, turns and motions that
`calibrate_recording` found, so a peer's calibration (imucal's, imu_tk's published parameters) is scored on the
very same data by `score_series`. A recording without segments (imu_tk's) is scored on the static poses its
turntable-free calibration detects, written back as static segments (no axis up) so they can be left out.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from rig.calibration.recordings.recording import RecordingCalibration, calibrate_recording
from rig.calibration.recordings.recording_fits import carried_errors
from rig.calibration.recordings.rests import rest_motions, unlabelled_rests
from rig.calibration.numerics.result import TriadCalibration
from rig.errors import CalibrationError
from rig.session_data import MoveStream, SessionData, filled

FORMAT = "rig-heldout/1"
Calibrate = Callable[..., RecordingCalibration]


@dataclass
class Scores:
    """Errors per pose, turn and motion; None where that piece could not be predicted (the reason in `notes`)."""

    pose_rms: list[float | None]          # m/s^2, RMS of |a| - g over the pose's samples
    pose_mean_error: list[float | None]   # m/s^2, |mean a| - g
    turn_error_deg: list[float | None]
    carry_error_deg: list[float | None]
    rest_rms: list[float] = field(default_factory=list)          # m/s^2, at rests no segment names
    rest_mean_error: list[float] = field(default_factory=list)
    rest_carry_error_deg: list[float] = field(default_factory=list)  # motions into and out of those rests
    notes: list[str] = field(default_factory=list)
    format: str = FORMAT

    def summary(self) -> dict:
        """RMS over the pieces that were predicted, and how many of how many."""
        def rms(values):
            v = np.array([x for x in values if x is not None], dtype=float)
            return {"rms": float(np.sqrt(np.mean(v ** 2))) if v.size else None, "n": int(v.size), "of": len(values)}
        return {"accel_pose_rms": rms(self.pose_rms), "accel_pose_mean_error": rms(self.pose_mean_error),
                "gyro_turn_deg": rms(self.turn_error_deg), "gyro_carry_deg": rms(self.carry_error_deg),
                "accel_rest_rms": rms(self.rest_rms), "accel_rest_mean_error": rms(self.rest_mean_error),
                "gyro_rest_carry_deg": rms(self.rest_carry_error_deg)}


def scoring_layout(session: SessionData, calibrate: Calibrate = calibrate_recording
                   ) -> tuple[SessionData, RecordingCalibration]:
    """The session whose poses can be left out, and its calibration on everything."""
    rec = calibrate(session)
    if session.meta.get("segments"):
        return session, rec
    laid = copy.copy(session)
    laid.meta = dict(session.meta)
    laid.meta["segments"] = [{"name": p.name, "t0": float(session.t[p.rows[0]]), "t1": float(session.t[p.rows[-1]]),
                              "kind": "static"} for p in rec.poses]
    return laid, calibrate(laid)


def series(session: SessionData, sensors: dict[str, TriadCalibration]) -> dict[str, np.ndarray]:
    """Calibrated accelerometer and gyroscope of every row (the gyro less its g-sensitivity where it has one)."""
    out = {s: sensors[s].apply(session.raw[s]) for s in ("accel", "gyro") if s in sensors and s in session.raw}
    if "gyro" in out and sensors["gyro"].g_sensitivity is not None:
        force = sensors["accel"].apply(filled(session.raw["accel"]))
        out["gyro"] = sensors["gyro"].apply(session.raw["gyro"], force)
    return out


def pose_errors(accel: np.ndarray, rows: np.ndarray, g: float) -> tuple[float, float]:
    a = accel[rows]
    a = a[~np.isnan(a).any(axis=1)]
    return (float(np.sqrt(np.mean((np.linalg.norm(a, axis=1) - g) ** 2))),
            float(np.linalg.norm(a.mean(axis=0)) - g))


def turn_error_deg(session: SessionData, gyro: np.ndarray, turn) -> float:
    """Calibrated rate summed over the turn (rectangle rule, as the fit), about its axis, minus the known angle."""
    w, t = gyro[turn.rows], session.t[turn.rows]
    ok = ~np.isnan(w).any(axis=1)
    w, t = w[ok], t[ok]
    return float(np.degrees((w[:-1] * np.diff(t)[:, None]).sum(axis=0) @ turn.axis - turn.angle_rad))


def carry_error_deg(session: SessionData, cal: dict[str, np.ndarray], a: np.ndarray, b: np.ndarray) -> float:
    """Angle between the gravity direction of the still rows a, carried by the calibrated gyro to the still rows b
    after them, and b's."""
    g = []
    for rows in (a, b):
        m = np.nanmean(cal["accel"][rows], axis=0)
        g.append(m / np.linalg.norm(m))
    idx = np.arange(a[-1], b[0] + 1)
    w = cal["gyro"][idx]
    ok = ~np.isnan(w).any(axis=1)
    stream = MoveStream(0, session.t[idx][ok], w[ok], np.eye(3), np.eye(3))
    return float(np.degrees(carried_errors(np.eye(3), np.zeros(3), [stream], g[0][None], g[1][None])[0]))


def score_series(session: SessionData, rec: RecordingCalibration, cal: dict[str, np.ndarray]) -> Scores:
    """A fixed calibration (its calibrated series) scored on every pose, turn and motion of `rec`: in-sample for
    whatever that calibration was fitted on."""
    errors = [pose_errors(cal["accel"], p.rows, session.gravity) for p in rec.poses]
    rest_rows = unlabelled_rests(session, rec)
    rests = [pose_errors(cal["accel"], rows, session.gravity) for rows in rest_rows]
    has_gyro = "gyro" in cal
    return Scores([e[0] for e in errors], [e[1] for e in errors],
                  [turn_error_deg(session, cal["gyro"], t) if has_gyro else None for t in rec.turns],
                  [carry_error_deg(session, cal, rec.poses[i].rows, rec.poses[j].rows) if has_gyro else None
                   for i, j in rec.carries], [e[0] for e in rests], [e[1] for e in rests],
                  [carry_error_deg(session, cal, a, b) for a, b in rest_motions(session, rec, rest_rows)]
                  if has_gyro else [])


def heldout_scores(session: SessionData, calibrate: Calibrate = calibrate_recording) -> tuple[Scores, Scores]:
    """(held-out, in-sample) scores of our calibration: every pose, turn and motion predicted by a refit without
    it, and the same pieces under the fit on everything. `calibrate` takes `calibrate_recording`'s `leave_out`,
    `gyro_start` and `accel`."""
    laid, full = scoring_layout(session, calibrate)
    inside = score_series(laid, full, series(laid, full.sensors))
    accel_only = copy.copy(laid)
    accel_only.raw = {s: y for s, y in laid.raw.items() if s != "gyro"}      # the accelerometer's fit needs no gyro
    out = Scores([], [], [], [], inside.rest_rms, inside.rest_mean_error,     # no segment fitted the rests
                 inside.rest_carry_error_deg)
    for i, pose in enumerate(full.poses):
        sensors = _refit(calibrate, accel_only, {"poses": [i]}, f"pose {pose.name}", out.notes)
        rms, mean = pose_errors(series(laid, sensors)["accel"], pose.rows, laid.gravity) if sensors else (None, None)
        out.pose_rms.append(rms)
        out.pose_mean_error.append(mean)
    from_full_fit = ({"gyro_start": full.sensors["gyro"].H, "accel": full.sensors["accel"]}
                     if "gyro" in full.sensors else {})
    for k, turn in enumerate(full.turns):
        sensors = _refit(calibrate, laid, {"turns": [k]}, f"turn {turn.name}", out.notes, from_full_fit)
        out.turn_error_deg.append(turn_error_deg(laid, series(laid, sensors)["gyro"], turn) if sensors else None)
    for c, (i, j) in enumerate(full.carries):
        sensors = _refit(calibrate, laid, {"carries": [c]}, f"motion {full.poses[i].name}->{full.poses[j].name}",
                         out.notes, from_full_fit)
        a, b = full.poses[i].rows, full.poses[j].rows
        out.carry_error_deg.append(carry_error_deg(laid, series(laid, sensors), a, b) if sensors else None)
    return out, inside


def _refit(calibrate: Calibrate, session: SessionData, leave_out: dict, what: str, notes: list[str],
           from_full_fit: dict | None = None):
    try:
        return calibrate(session, leave_out=leave_out, **(from_full_fit or {})).sensors
    except CalibrationError as e:
        notes.append(f"{what} left out: {e}")
        return None
