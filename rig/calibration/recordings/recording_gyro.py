"""A recording's gyroscope: B from its static poses, H from turns of known angle and the gravity its motions carry
between poses (`recording_fits.gyro_rotation_fit`), with the covariance it inherits from the accelerometer's
frame those motions tie it to."""

from __future__ import annotations

import numpy as np

from rig.calibration.recordings.carry_choice import carry_weight_by_cross_validation
from rig.calibration.recordings.carry_weight import PRIOR, CarryWeight
from rig.calibration.recordings.recording_fits import carried_errors, gyro_rotation_fit, turn_angle
from rig.calibration.recordings.recording_vector import gravity_directions
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.recordings.segments import Pose, Turn
from rig.calibration.recordings.turntable_free_gyro import GAP_FACTOR
from rig.calibration.numerics.uncertainty import inherited_frame_cov
from rig.errors import CalibrationError
from rig.session_data import MoveStream, SessionData


def whole_carries(session: SessionData, poses: list[Pose]) -> list[tuple[int, int]]:
    """Consecutive poses whose motion between them was recorded whole (no gap in the samples): only those carry
    gravity."""
    dt = float(np.median(np.diff(session.t)))
    out = []
    for i in range(len(poses) - 1):
        a, b = poses[i].rows[-1], poses[i + 1].rows[0]
        if b <= a:
            continue
        gaps = np.diff(session.t[a:b + 1])
        if gaps.size and gaps.max() <= GAP_FACTOR * dt:
            out.append((i, i + 1))
    return out


def fit_gyro(session: SessionData, accel: TriadCalibration, poses: list[Pose], turns: list[Turn],
              carries: list[tuple[int, int]], leave_out: dict,
             carry: CarryWeight | None = None, H0: np.ndarray | None = None) -> tuple[TriadCalibration, dict]:
    y = session.raw["gyro"]
    stills = np.concatenate([p.rows for p in poses])
    still = y[stills]
    still = still[~np.isnan(still).any(axis=1)]
    B = still.mean(axis=0)
    B_std = still.std(axis=0, ddof=1) / np.sqrt(len(still))
    skip_turns, skip_carries = set(leave_out.get("turns", ())), set(leave_out.get("carries", ()))
    turn_terms = [(summed_rate(session, t.rows, B), t.axis, t.angle_rad, t.angle_sd_rad, t.axis_sd_rad)
                  for k, t in enumerate(turns) if k not in skip_turns]
    g = gravity_directions(session, accel, poses)
    streams = [motion(session, poses[i], poses[j]) for i, j in carries]
    carry_terms = [(streams[c], g[i], g[j]) for c, (i, j) in enumerate(carries) if c not in skip_carries]
    H, cov, info = gyro_rotation_fit(B, turn_terms, carry_terms, H0=H0)
    if carry is None:
        carry = PRIOR
        if turn_terms and carry_terms and info["rank"] == 9:
            carry = carry_weight_by_cross_validation(B, turn_terms, carry_terms, H)
    if not carry.fits_motions:
        carry_terms = []
    if carry != PRIOR:
        H, cov, info = gyro_rotation_fit(B, turn_terms, carry_terms, H0=H, carry=carry)
    if info["rank"] < 9:
        raise CalibrationError(f"gyro: the turns and motions left in the fit determine only {info['rank']} of H's 9 "
                               "entries")
    inherited = inherited_frame_cov(accel, H) if carry_terms else None      # motions tie it to the accel's frame
    if inherited is not None:
        cov = cov + inherited
    angle_err = [np.degrees(turn_angle(H, summed_rate(session, t.rows, B), t.axis) - t.angle_rad) for t in turns]
    fitted = info["moveset"] if not skip_carries else None          # the fit's motions are all of them
    carry_err = np.degrees(carried_errors(H, B, streams, g[[i for i, _ in carries]], g[[j for _, j in carries]],
                                          fitted)).tolist() if carries else []
    resid = np.radians(np.r_[angle_err, carry_err])
    cal = TriadCalibration(
        B=B, H=H, method=_method(bool(carry_terms), bool(carries)),
        residual_rms=float(np.sqrt(np.mean(resid ** 2))) if resid.size else float("nan"),
        iterations=info["iterations"], converged=info["converged"], B_std=B_std,
        H_std=np.sqrt(np.clip(np.diag(cov), 0, None)).reshape(3, 3), H_cov=cov,
        extra={"turns": [t.name for t in turns], "turn_angle_error_deg": angle_err,
               "carries": [[poses[i].name, poses[j].name] for i, j in carries], "carry_error_deg": carry_err,
               "residual_unit": "rad (turn angles, carried gravity)",
               "turns_fitted_exactly": not carry_terms and 3 * len(turn_terms) <= 9,
               **(carry.extra() if carries else {"carry_sd": None, "carry_angle_sd": None}),
               "loo_scatter_to_predicted": info["loo_scatter_to_predicted"]})
    return cal, {"turns": len(turn_terms), "carries": len(carry_terms)}


def _method(motions_fitted: bool, motions: bool) -> str:
    if motions_fitted:
        return "recording-turns (known turns and gravity carried between poses)"
    if motions:
        return "recording-turns (known turns alone; the gravity carried between poses scored, not fitted)"
    return "recording-turns (known turns)"


def summed_rate(session: SessionData, rows: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Sum of (y - B) dt over a turn's samples (rectangle rule): H of it is the turn's rotation vector."""
    y = session.raw["gyro"][rows] - B
    t = session.t[rows]
    ok = ~np.isnan(y).any(axis=1)
    y, t = y[ok], t[ok]
    return (y[:-1] * np.diff(t)[:, None]).sum(axis=0)


def motion(session: SessionData, a: Pose, b: Pose) -> MoveStream:
    """The gyro stream from the last sample of pose a to the first of pose b."""
    idx = np.arange(a.rows[-1], b.rows[0] + 1)
    y = session.raw["gyro"][idx]
    ok = ~np.isnan(y).any(axis=1)
    return MoveStream(0, session.t[idx][ok], y[ok], np.eye(3), np.eye(3))
