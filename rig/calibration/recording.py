"""Calibrate a recording without a turntable from what its segments say (session-csv.md, "Recordings without a
turntable"): static poses (with the axis that was up, and how far the hand may have tilted it), turns of known
angle about a sensor axis, and the motions between poses; where nothing is said, imu_tk's turntable-free method
with static intervals found in the data (`turntable_free`). The fits are in `recording_fits`.

`leave_out` drops poses, turns or motions from the fit, by index in time order, so the same code scores what a
calibration predicts for data it did not see (held-out prediction).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.calibration.g_sensitivity import with_g_sensitivity
from rig.calibration.recording_checks import (
    check_no_stuck_axis,
    imported_columns,
    refused_for_saturation,
    unclipped_turns_and_motions,
    unsaturated_poses,
)
from rig.calibration.recording_fits import (
    CARRY_SD,
    carried_errors,
    carry_sd_by_cross_validation,
    fit_faces,
    gyro_rotation_fit,
    turn_angle,
)
from rig.calibration.recording_mag import calibrate_recording_mag
from rig.calibration.result import TriadCalibration
from rig.calibration.segments import DEFAULT_TILT_SD_DEG, Pose, Turn, segments_of
from rig.calibration.turntable_free import (
    GAP_FACTOR,
    SAMPLES_PER_INTERVAL,
    calibrate_turntable_free,
    fit_accel_upper,
)
from rig.calibration.uncertainty import inherited_frame_cov
from rig.errors import CalibrationError
from rig.session_data import MoveStream, SessionData


MIN_AXIS_SD = float(np.radians(0.1))      # a turn's axis from the gyro, at best (rad)


@dataclass
class RecordingCalibration:
    """Per-sensor calibrations and what the recording contributed to them."""

    sensors: dict[str, TriadCalibration]
    poses: list[Pose]
    turns: list[Turn]
    carries: list[tuple[int, int]]                 # (pose index, next pose index) whose motion carried gravity
    warnings: list[str] = field(default_factory=list)


def calibrate_recording(session: SessionData, *, leave_out: dict | None = None,
                        carry_sd: float | None = None, gyro_start: np.ndarray | None = None,
                        g_sensitivity: bool = False) -> RecordingCalibration:
    """Accelerometer (and magnetometer) from the static poses, gyroscope from turns and motions between poses.

    leave_out: {"poses": [i, ...], "turns": [k, ...], "carries": [c, ...]} not used in the fit.
    carry_sd: how far a hand motion's carried gravity is trusted; None: chosen by cross-validation where turns
    say it too (the twin's replicas take the recording's choice rather than choosing again).
    gyro_start: where the gyro's fit starts instead of its own coarse search (a twin's replica starts at its
    recording's H: the same optimum, to 1e-10, in a third less time).
    g_sensitivity: take the gyro's g-sensitivity into its calibration where the poses show it
    (`rig.calibration.g_sensitivity`; what `rig calibrate` writes). The twin keeps the linear model, and names it.
    """
    rec = _calibrate_linear(session, leave_out, carry_sd, gyro_start)
    if g_sensitivity and "gyro" in rec.sensors:
        left = set((leave_out or {}).get("poses", ()))
        gyro = with_g_sensitivity(session, rec.sensors, [p.rows for i, p in enumerate(rec.poses) if i not in left],
                                  lambda s: _calibrate_linear(s, leave_out, carry_sd, gyro_start).sensors["gyro"])
        if gyro is not None:
            rec.sensors["gyro"] = gyro
    return rec


def _calibrate_linear(session: SessionData, leave_out: dict | None, carry_sd: float | None,
                      gyro_start: np.ndarray | None) -> RecordingCalibration:
    check_no_stuck_axis(session)
    poses, turns = segments_of(session)
    if not poses:
        return _turntable_free(session)
    if "accel" not in session.raw:
        raise CalibrationError(f"{session.source}: a recording needs its accelerometer for the static poses")
    poses, saturated = unsaturated_poses(session, poses)
    if not poses:
        raise CalibrationError(f"{session.source}: no static pose is left once {'; '.join(w for _, w in saturated)}")
    leave_out = leave_out or {}
    use_poses = [p for i, p in enumerate(poses) if i not in set(leave_out.get("poses", ()))]
    sensors, warnings = {}, [w for w, _ in saturated]
    with refused_for_saturation(session, [why for _, why in saturated]):
        sensors["accel"] = _vector_fit(session, "accel", use_poses, session.gravity)
    carries = _carries(session, poses)
    if "gyro" in session.raw:
        turns, carries, clipped = unclipped_turns_and_motions(session, poses, turns, carries)
        warnings += [w for w, _ in clipped]
        with refused_for_saturation(session, [why for _, why in clipped]):
            sensors["gyro"], used = fit_gyro(session, sensors["accel"], poses, turns, carries, leave_out,
                                             carry_sd, gyro_start)
        if not used["turns"] and not used["carries"]:
            warnings.append("gyro: no turn of known angle and no whole motion between poses")
    if "mag" in session.raw:
        left = [p.rows for i, p in enumerate(poses) if i in set(leave_out.get("poses", ()))]
        sensors["mag"], mag_warnings = _mag(session, sensors["accel"], use_poses, _turn_axes(session, sensors, turns),
                                            np.concatenate(left) if left else None)
        warnings += mag_warnings
    return RecordingCalibration(sensors, poses, turns, carries, warnings)


def _turn_axes(session: SessionData, sensors: dict, turns: list[Turn]) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Each turn's rows, its axis in the accelerometer's frame and that axis's standard deviation (rad): the
    calibrated gyro's summed rate, to within the gyro frame's own (a hand's axis is not the nominal one), else
    the nominal axis to within the turn's tilt prior."""
    gyro = sensors.get("gyro")
    if gyro is None or gyro.H_std is None:
        return [(t.rows, np.asarray(t.axis, float), t.axis_sd_rad) for t in turns]
    off = ~np.eye(3, dtype=bool)
    sd = max(float(np.sqrt(np.mean(gyro.H_std[off] ** 2)) / np.abs(np.diag(gyro.H)).mean()), MIN_AXIS_SD)
    return [(t.rows, gyro.H @ summed_rate(session, t.rows, gyro.B), sd) for t in turns]


def _mag(session: SessionData, accel: TriadCalibration, poses: list[Pose], turns: list,
         left_out_rows: np.ndarray | None) -> tuple[TriadCalibration, list[str]]:
    if not session.field_uT:
        raise CalibrationError(f"{session.source}: a magnetometer is calibrated to the local field magnitude, and the "
                               "session has none (field_uT)")
    return calibrate_recording_mag(session, accel, poses, float(session.field_uT), turns, left_out_rows)


def pose_stats(session: SessionData, sensor: str, poses: list[Pose]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    y = session.raw[sensor]
    means, se, counts = [], [], []
    for p in poses:
        v = y[p.rows]
        v = v[~np.isnan(v).any(axis=1)]
        if len(v) < 2:
            raise CalibrationError(f"{sensor}: pose {p.name} has fewer than two samples")
        means.append(v.mean(axis=0))
        se.append(v.std(axis=0, ddof=1) / np.sqrt(len(v)))
        counts.append(len(v))
    return np.array(means), np.array(se), np.array(counts)


def _vector_fit(session: SessionData, sensor: str, poses: list[Pose], norm: float) -> TriadCalibration:
    means, se, counts = pose_stats(session, sensor, poses)
    ups = [p.up if sensor == "accel" else None for p in poses]
    rows = np.concatenate([p.rows for p in poses])
    y = session.raw[sensor][rows]
    y = y[~np.isnan(y).any(axis=1)]
    if sum(u is not None for u in ups) < 3:
        return _norm_only_fit(session, sensor, poses, norm, y)
    tilt_sd = np.radians([p.tilt_sd_deg for p in poses])
    B, H, u, info = fit_faces(means, se, ups, tilt_sd, norm)
    rms = float(np.sqrt(np.mean((np.linalg.norm((y - B) @ H.T, axis=1) - norm) ** 2)))
    pose_err = np.linalg.norm((means - B) @ H.T, axis=1) - norm
    cov = info["cov"]
    return TriadCalibration(
        B=B, H=H, method="recording-faces (norm, faces tilted within their prior)", residual_rms=rms,
        iterations=info["iterations"], converged=info["converged"],
        B_std=np.sqrt(np.clip(np.diag(cov)[:3], 0, None)), H_std=np.sqrt(np.clip(np.diag(cov)[3:], 0, None)).reshape(3, 3),
        B_cov=cov[:3, :3], H_cov=cov[3:, 3:],
        extra={"poses": [p.name for p in poses], "pose_tilt_deg": info["tilt_deg"],
               "pose_norm_error": pose_err.tolist(), "gravity_direction": u.tolist(),
               "samples": int(counts.sum())})


def _norm_only_fit(session: SessionData, sensor: str, poses: list[Pose], norm: float, y: np.ndarray) -> TriadCalibration:
    """No pose says which axis was up: |H (y - B)| = norm over every pose sample, H upper triangular (imu_tk's
    convention: without known orientations the sensor frame is the one H defines)."""
    if len(poses) < 9:
        raise CalibrationError(f"{sensor}: {len(poses)} static poses and none says which axis was up; the norm model "
                               "needs at least 9")
    chunks = [session.raw[sensor][p.rows][~np.isnan(session.raw[sensor][p.rows]).any(axis=1)] for p in poses]
    B, H, cost = fit_accel_upper([c[:SAMPLES_PER_INTERVAL] for c in chunks], norm)      # imu_tk fits 100 a pose
    rms = float(np.sqrt(np.mean((np.linalg.norm((y - B) @ H.T, axis=1) - norm) ** 2)))
    means = np.array([c.mean(axis=0) for c in chunks])
    return TriadCalibration(B=B, H=H, method="recording-norm (upper-triangular H, imu_tk convention)",
                            residual_rms=rms, extra={"poses": [p.name for p in poses],
                                                     "pose_norm_error": (np.linalg.norm((means - B) @ H.T, axis=1)
                                                                         - norm).tolist(), "cost": cost})


def _carries(session: SessionData, poses: list[Pose]) -> list[tuple[int, int]]:
    """Consecutive poses whose motion between them was recorded whole (no gap in the samples)."""
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
             carry_sd: float | None = None, H0: np.ndarray | None = None) -> tuple[TriadCalibration, dict]:
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
    if carry_sd is None:
        carry_sd = CARRY_SD
        if turn_terms and carry_terms and info["rank"] == 9:
            carry_sd = carry_sd_by_cross_validation(B, turn_terms, carry_terms, H)
    if carry_sd != CARRY_SD:
        H, cov, info = gyro_rotation_fit(B, turn_terms, carry_terms, H0=H, carry_sd=carry_sd)
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
        B=B, H=H, method="recording-turns (known turns and gravity carried between poses)",
        residual_rms=float(np.sqrt(np.mean(resid ** 2))) if resid.size else float("nan"),
        iterations=info["iterations"], converged=info["converged"], B_std=B_std,
        H_std=np.sqrt(np.clip(np.diag(cov), 0, None)).reshape(3, 3), H_cov=cov,
        extra={"turns": [t.name for t in turns], "turn_angle_error_deg": angle_err,
               "carries": [[poses[i].name, poses[j].name] for i, j in carries], "carry_error_deg": carry_err,
               "residual_unit": "rad (turn angles, carried gravity)",
               "carry_sd": carry_sd if carries else None})
    return cal, {"turns": len(turn_terms), "carries": len(carry_terms)}


def summed_rate(session: SessionData, rows: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Sum of (y - B) dt over a turn's samples (rectangle rule): H of it is the turn's rotation vector."""
    y = session.raw["gyro"][rows] - B
    t = session.t[rows]
    ok = ~np.isnan(y).any(axis=1)
    y, t = y[ok], t[ok]
    return (y[:-1] * np.diff(t)[:, None]).sum(axis=0)


def gravity_directions(session: SessionData, accel: TriadCalibration, poses: list[Pose]) -> np.ndarray:
    """Unit gravity direction of every pose from the calibrated accelerometer, (k, 3)."""
    y = session.raw["accel"]
    out = []
    for p in poses:
        v = y[p.rows]
        a = accel.apply(v[~np.isnan(v).any(axis=1)].mean(axis=0, keepdims=True))[0]
        out.append(a / np.linalg.norm(a))
    return np.array(out)


def motion(session: SessionData, a: Pose, b: Pose) -> MoveStream:
    """The gyro stream from the last sample of pose a to the first of pose b."""
    idx = np.arange(a.rows[-1], b.rows[0] + 1)
    y = session.raw["gyro"][idx]
    ok = ~np.isnan(y).any(axis=1)
    return MoveStream(0, session.t[idx][ok], y[ok], np.eye(3), np.eye(3))


def _turntable_free(session: SessionData) -> RecordingCalibration:
    """No segments: imu_tk's method, static intervals detected in the data (a record starting at rest)."""
    if "accel" not in session.raw or "gyro" not in session.raw:
        raise CalibrationError(f"{session.source}: a recording without segments needs an accelerometer and a "
                               "gyroscope (imu_tk's turntable-free method)")
    accel, gyro = session.raw["accel"], session.raw["gyro"]
    rows = ~(np.isnan(accel).any(axis=1) | np.isnan(gyro).any(axis=1))
    try:
        sensors = calibrate_turntable_free(session.t[rows], accel[rows], gyro[rows], gravity=session.gravity,
                                           columns={s: imported_columns(session, s) for s in ("accel", "gyro")})
    except (CalibrationError, ValueError) as exc:       # name the recording, as every other refusal here does
        raise CalibrationError(f"{session.source}: {exc}") from None
    intervals = sensors["accel"].extra["intervals"]
    index = np.flatnonzero(rows)
    poses = [Pose(f"static {k}", index[a:b + 1], None, DEFAULT_TILT_SD_DEG) for k, (a, b) in enumerate(intervals)]
    sensors, warnings = dict(sensors), ["no segments: static intervals detected in the data (imu_tk's turntable-free "
                                        "method; the record must start with a long rest)"]
    if "mag" in session.raw:
        sensors["mag"], mag_warnings = _mag(session, sensors["accel"], poses, [], None)
        warnings += mag_warnings
    return RecordingCalibration(sensors, poses, [], [(i, i + 1) for i in sensors["gyro"].extra["whole_motions"]],
                                warnings)
