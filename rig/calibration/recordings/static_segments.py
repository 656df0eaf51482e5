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

from rig.calibration.recordings.recording_gyro import summed_rate
from rig.calibration.recordings.segments import Pose, Turn
from rig.calibration.numerics.static_detect import window_samples
from rig.errors import InputError
from rig.session_data import SessionData

TURN_LIMIT_DEG = 5.0          # within one second; 50 times what the real poses show
WINDOW_S = 1.0
DEG_PER = {"deg/s": 1.0, "rad/s": float(np.degrees(1.0))}


def check_static_segments(session: SessionData, poses: list[Pose], turns: list[Turn]) -> None:
    """Refuse (InputError, exit 2) the first static segment in which the unit turns (module docstring).

    Every window's mean comes from one running sum per sensor (a pose's rows are contiguous): the check runs on every
    calibration, the twin's replicas' too (6 ms for the Xsens's 38 poses, where a median per pose took 13)."""
    if not poses:
        return
    win = window_samples(session.t, WINDOW_S)
    sums = {s: _running_sums(session.raw[s]) for s in ("accel", "gyro") if s in session.raw}
    gyro_deg = bias = None
    if "gyro" in sums:                   # the median of the poses' mean rates: a pose that holds a turn moves its own
        bias = np.median([_mean(sums["gyro"], p.rows[0], p.rows[-1] + 1) for p in poses], axis=0)
        gyro_deg = _gyro_degrees_per_unit(session, turns, bias)
    if gyro_deg is None:
        sums.pop("gyro", None)
    for pose in poses:
        a, b = int(pose.rows[0]), int(pose.rows[-1]) + 1
        if b - a < win:
            continue
        turned = np.zeros(b - a - win + 1)
        if "accel" in sums:
            means, u = _window_means(sums["accel"], a, b, win), _mean(sums["accel"], a, b)
            cos = means @ u / np.maximum(np.linalg.norm(means, axis=1) * np.linalg.norm(u), 1e-300)
            turned = np.fmax(turned, np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
        if "gyro" in sums:
            rate = np.linalg.norm(_window_means(sums["gyro"], a, b, win) - bias, axis=1)
            turned = np.fmax(turned, rate * gyro_deg * WINDOW_S)
        if turned.max() > TURN_LIMIT_DEG:
            _refuse(session, pose, session.t[a:b], turned)


def _running_sums(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Running sums of a stream's samples (NaN rows count as none) and of how many there are, from 0."""
    ok = ~np.isnan(y).any(axis=1)
    total = np.vstack([np.zeros((1, 3)), np.cumsum(np.where(ok[:, None], y, 0.0), axis=0)])
    return total, np.concatenate([[0], np.cumsum(ok)])


def _window_means(sums: tuple[np.ndarray, np.ndarray], a: int, b: int, win: int) -> np.ndarray:
    """Mean of each window of `win` rows within rows a..b-1 (NaN where a window holds no sample)."""
    total, count = sums
    n = (count[a + win:b + 1] - count[a:b + 1 - win]).astype(float)
    return (total[a + win:b + 1] - total[a:b + 1 - win]) / np.where(n > 0, n, np.nan)[:, None]


def _mean(sums: tuple[np.ndarray, np.ndarray], a: int, b: int) -> np.ndarray:
    total, count = sums
    return (total[b] - total[a]) / max(count[b] - count[a], 1)


def _refuse(session: SessionData, pose: Pose, t: np.ndarray, turned: np.ndarray) -> None:
    first = int(np.flatnonzero(turned > TURN_LIMIT_DEG)[0])
    raise InputError(f"{Path(session.source) / 'meta.json'}: static segment '{pose.name}' (t {t[0]:.3f} to "
                     f"{t[-1]:.3f} s) holds a motion: the unit turns {turned[first]:.1f} deg in the second from t "
                     f"{t[first]:.3f} s ({turned.max():.0f} deg in its worst second), where a static pose turns less "
                     f"than {TURN_LIMIT_DEG:g} deg. Its t0 and t1 must leave out the turns and the motions between poses")


def _gyro_degrees_per_unit(session: SessionData, turns: list[Turn], bias: np.ndarray) -> float | None:
    """Degrees per unit of the raw gyro: its unit's, or for counts the turns' known angles over their summed
    counts (None in counts without a turn)."""
    unit = (session.meta.get("units") or {}).get("gyro")
    if unit in DEG_PER:
        return DEG_PER[unit]
    summed = [np.linalg.norm(summed_rate(session, turn.rows, bias)) for turn in turns]
    ratios = [abs(np.degrees(turn.angle_rad)) / m for turn, m in zip(turns, summed) if m > 0]
    return float(np.median(ratios)) if ratios else None
