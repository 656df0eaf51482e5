"""The table's reference angles between encoder polls.

Polls carry position and velocity, so a cubic Hermite spline through them keeps the rate ramps: a
straight line between 10 Hz polls misses them by up to a degree at the rates of a calibration move.
The spline is scipy's `CubicHermiteSpline` written out in numpy (tests/planner/test_reference_spline.py holds
them equal): importing scipy.interpolate cost a simulated session a sixth of its wall time.
"""

from __future__ import annotations

import numpy as np


def hermite(x: np.ndarray, y: np.ndarray, dydx: np.ndarray, at: np.ndarray) -> np.ndarray:
    """The piecewise cubic through (x, y) with slopes dydx (x strictly increasing), evaluated at `at` in [x0, xn]."""
    k = np.clip(np.searchsorted(x, at, side="right") - 1, 0, len(x) - 2)
    h = x[k + 1] - x[k]
    s = (at - x[k]) / h
    h00, h10 = (1 + 2 * s) * (1 - s) ** 2, s * (1 - s) ** 2
    h01, h11 = s * s * (3 - 2 * s), s * s * (s - 1)
    return h00 * y[k] + h10 * h * dydx[k] + h01 * y[k + 1] + h11 * h * dydx[k + 1]


def interpolate_angles(t: np.ndarray, poll_t, poll_pos, poll_vel) -> np.ndarray:
    """Angles (n, 2) in degrees at times t from polls (times, positions (m, 2) deg, velocities (m, 2) deg/s)."""
    pt, pp, pv = np.asarray(poll_t, float), np.asarray(poll_pos, float), np.asarray(poll_vel, float)
    keep = np.concatenate([[True], np.diff(pt) > 0])
    pt, pp, pv = pt[keep], pp[keep], pv[keep]
    if len(pt) < 2:
        return np.tile(pp[0], (len(t), 1))
    tc = np.clip(np.asarray(t, float), pt[0], pt[-1])
    return np.column_stack([hermite(pt, pp[:, i], pv[:, i], tc) for i in range(2)])
