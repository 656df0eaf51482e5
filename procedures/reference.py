"""The table's reference angles between encoder polls.

Polls carry position and velocity, so a cubic Hermite spline through them (scipy's `CubicHermiteSpline`) keeps the
rate ramps: a straight line between 10 Hz polls misses them by up to a degree at the rates of a calibration move.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicHermiteSpline


def interpolate_angles(t: np.ndarray, poll_t, poll_pos, poll_vel) -> np.ndarray:
    """Angles (n, 2) in degrees at times t from polls (times, positions (m, 2) deg, velocities (m, 2) deg/s)."""
    pt, pp, pv = np.asarray(poll_t, float), np.asarray(poll_pos, float), np.asarray(poll_vel, float)
    keep = np.concatenate([[True], np.diff(pt) > 0])
    pt, pp, pv = pt[keep], pp[keep], pv[keep]
    if len(pt) < 2:
        return np.tile(pp[0], (len(t), 1))
    tc = np.clip(np.asarray(t, float), pt[0], pt[-1])
    return CubicHermiteSpline(pt, pp, pv, axis=0)(tc)
