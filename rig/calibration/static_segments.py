"""A static segment the user wrote must hold the unit still: one whose time range runs into a motion or holds a turn
is refused, naming it, before any fit.

Nothing else would notice. The fits take a pose's mean as one attitude: imucal's SI session with its x_p segment
run 2 s into the flip after it, or its x_rot turn written as a static pose, calibrated with exit 0 to a gyro bias of
5 and -9.7 deg/s and a gyro scale 22 % off. Hand poses are far from this: on the three real recordings with
segments no 1 s mean of the gyro departs from its pose's median by more than 0.07 deg/s, and no 1 s mean of the
accelerometer turns from the pose's direction by more than 0.1 deg; those two faults turn by 193 and 216 deg/s.

A segment is refused where, over some second of it, the unit turns by more than `TURN_LIMIT_DEG`: the gyro's mean
rate (less the pose's median, its bias) times the second, or the angle between the accelerometer's mean and the
pose's median direction. A gyro in counts is read at the scale its turns of known angle give; without turns only
the accelerometer is looked at (it cannot see a turn about the vertical).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.calibration.gyro_still import window_means
from rig.calibration.segments import Pose, Turn
from rig.calibration.static_detect import window_samples
from rig.errors import InputError
from rig.session_data import SessionData

TURN_LIMIT_DEG = 5.0          # within one second; 50 times what the real poses show
WINDOW_S = 1.0
DEG_PER = {"deg/s": 1.0, "rad/s": float(np.degrees(1.0))}


def check_static_segments(session: SessionData, poses: list[Pose], turns: list[Turn]) -> None:
    """Refuse (InputError, exit 2) the first static segment in which the unit turns (module docstring)."""
    win = window_samples(session.t, WINDOW_S)
    gyro_deg = _gyro_degrees_per_unit(session, poses, turns)
    seen = [s for s in ("accel", "gyro") if s in session.raw and (s == "accel" or gyro_deg is not None)]
    if not seen:
        return
    for pose in poses:
        rows = pose.rows[~np.any([np.isnan(session.raw[s][pose.rows]).any(axis=1) for s in seen], axis=0)]
        if len(rows) < win:
            continue
        turned = np.zeros(len(rows) - win + 1)
        if "accel" in seen:
            turned = np.maximum(turned, _tilt_deg(session.raw["accel"][rows], win))
        if "gyro" in seen:
            turned = np.maximum(turned, _rate(session.raw["gyro"][rows], win) * gyro_deg * WINDOW_S)
        if turned.max() > TURN_LIMIT_DEG:
            _refuse(session, pose, session.t[rows], turned)


def _refuse(session: SessionData, pose: Pose, t: np.ndarray, turned: np.ndarray) -> None:
    first = int(np.flatnonzero(turned > TURN_LIMIT_DEG)[0])
    raise InputError(f"{Path(session.source) / 'meta.json'}: static segment '{pose.name}' (t {t[0]:.3f} to "
                     f"{t[-1]:.3f} s) holds a motion: the unit turns {turned[first]:.1f} deg in the second from t "
                     f"{t[first]:.3f} s ({turned.max():.0f} deg in its worst second), where a static pose turns less "
                     f"than {TURN_LIMIT_DEG:g} deg. Its t0 and t1 must leave out the turns and the motions between poses")


def _tilt_deg(y: np.ndarray, win: int) -> np.ndarray:
    """Angle (deg) of each window's mean from the pose's median direction."""
    means = window_means(y, win)
    u = np.median(y, axis=0)
    cos = means @ u / np.maximum(np.linalg.norm(means, axis=1) * np.linalg.norm(u), 1e-300)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _rate(y: np.ndarray, win: int) -> np.ndarray:
    """Magnitude of each window's mean rate less the pose's median (its bias), in the gyro's units."""
    return np.linalg.norm(window_means(y - np.median(y, axis=0), win), axis=1)


def _gyro_degrees_per_unit(session: SessionData, poses: list[Pose], turns: list[Turn]) -> float | None:
    """Degrees per unit of the raw gyro: its unit's, or for counts the turns' known angles over their summed
    counts (None without a gyro, or in counts without a turn)."""
    if "gyro" not in session.raw:
        return None
    unit = (session.meta.get("units") or {}).get("gyro")
    if unit in DEG_PER:
        return DEG_PER[unit]
    if not turns or not poses:
        return None
    y = session.raw["gyro"]
    bias = np.nanmedian(y[np.concatenate([p.rows for p in poses])], axis=0)
    ratios = []
    for turn in turns:
        rows = turn.rows[~np.isnan(y[turn.rows]).any(axis=1)]
        summed = ((y[rows[:-1]] - bias) * np.diff(session.t[rows])[:, None]).sum(axis=0)
        if np.linalg.norm(summed) > 0:
            ratios.append(abs(np.degrees(turn.angle_rad)) / np.linalg.norm(summed))
    return float(np.median(ratios)) if ratios else None
