"""A recording's accelerometer (and magnetometer where its poses say which axis was up) from its static poses: the
faces' model with their tilts where at least three say which axis was up, else the norm alone (imu_tk's
upper-triangular convention)."""

from __future__ import annotations

import numpy as np

from rig.calibration.numerics.norm_fit_cov import stated_uncertainty
from rig.calibration.recordings.recording_fits import fit_faces
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.recordings.segments import Pose
from rig.calibration.recordings.turntable_free import fit_accel_upper
from rig.errors import CalibrationError
from rig.session_data import SessionData


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


def vector_fit(session: SessionData, sensor: str, poses: list[Pose], norm: float) -> TriadCalibration:
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
    B, H, cost = fit_accel_upper(chunks, norm)                      # each pose's mean: imu_tk fits 100 samples
    rms = float(np.sqrt(np.mean((np.linalg.norm((y - B) @ H.T, axis=1) - norm) ** 2)))
    means = np.array([c.mean(axis=0) for c in chunks])
    spread, basis, few = stated_uncertainty(chunks, B, H, norm)
    return TriadCalibration(B=B, H=H, method="recording-norm (upper-triangular H, imu_tk convention)",
                            residual_rms=rms, warnings=few, **spread,
                            extra={"poses": [p.name for p in poses], "uncertainty": basis,
                                   "pose_norm_error": (np.linalg.norm((means - B) @ H.T, axis=1) - norm).tolist(),
                                   "cost": cost})


def gravity_directions(session: SessionData, accel: TriadCalibration, poses: list[Pose]) -> np.ndarray:
    """Unit gravity direction of every pose from the calibrated accelerometer, (k, 3)."""
    y = session.raw["accel"]
    out = []
    for p in poses:
        v = y[p.rows]
        a = accel.apply(v[~np.isnan(v).any(axis=1)].mean(axis=0, keepdims=True))[0]
        out.append(a / np.linalg.norm(a))
    return np.array(out)
