"""Synthetic motion with an exactly known attitude, for the filter tests.

The body rate is a sum of raised-cosine pulses (smooth, so the sampled rate is a fair record of it);
the true attitude is integrated on 20 sub-steps per sample with the midpoint rate. The navigation
frame is magnetic ENU (what the filter estimates); `world_from_nav` lets a test put the reference in
another frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

G = 9.80665
M = 50.0
DIP_DEG = 60.0


def pulse(t: np.ndarray, t0: float, T: float) -> np.ndarray:
    """Raised cosine of unit peak on [t0, t0 + T]; its integral is T / 2."""
    on = (t >= t0) & (t <= t0 + T)
    return np.where(on, 0.5 * (1.0 - np.cos(2 * np.pi * (t - t0) / T)), 0.0)


# (axis, peak rad/s, start s, duration s): the first turns 120 deg about body y from level, through pitch 90 deg
DEFAULT_PULSES = [(1, math.radians(120.0), 2.0, 2.0), (0, 1.5, 3.0, 2.5), (2, -1.2, 4.5, 2.0),
                  (1, -math.radians(90.0), 6.5, 2.0), (0, -1.0, 8.0, 2.0), (2, 2.0, 9.0, 1.5)]


@dataclass
class Motion:
    t: np.ndarray
    omega: np.ndarray     # (n, 3) true body rate, rad/s
    R: np.ndarray         # (n, 3, 3) true fixture -> navigation
    gyro: np.ndarray
    accel: np.ndarray
    mag: np.ndarray       # NaN on odd rows (a 50 Hz magnetometer beside 100 Hz accel/gyro)
    field_nav: np.ndarray


def body_rate(t: np.ndarray, pulses=DEFAULT_PULSES) -> np.ndarray:
    w = np.zeros((len(t), 3))
    for axis, peak, t0, T in pulses:
        w[:, axis] += peak * pulse(t, t0, T)
    return w


def make_motion(seed: int = 0, *, duration_s: float = 12.0, rate_hz: float = 100.0, pulses=DEFAULT_PULSES,
                noise=(0.004, 0.012, 0.15), R0: np.ndarray | None = None, mag_every: int = 2) -> Motion:
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    t = np.arange(int(round(duration_s * rate_hz)) + 1) * dt
    sub = 20
    R = np.empty((len(t), 3, 3))
    R[0] = np.eye(3) if R0 is None else R0
    h = dt / sub
    for k in range(1, len(t)):
        mids = t[k - 1] + (np.arange(sub) + 0.5) * h
        steps = Rotation.from_rotvec(body_rate(mids, pulses) * h)
        acc = Rotation.from_matrix(R[k - 1])
        for s in steps:
            acc = acc * s
        R[k] = acc.as_matrix()
    omega = body_rate(t, pulses)
    dip = math.radians(DIP_DEG)
    field_nav = M * np.array([0.0, math.cos(dip), -math.sin(dip)])
    accel = np.einsum("nji,j->ni", R, [0.0, 0.0, G]) + rng.normal(0.0, noise[1], (len(t), 3))
    mag = np.einsum("nji,j->ni", R, field_nav) + rng.normal(0.0, noise[2], (len(t), 3))
    gyro = omega + rng.normal(0.0, noise[0], (len(t), 3))
    if mag_every > 1:
        mag[np.arange(len(t)) % mag_every != 0] = np.nan
    return Motion(t, omega, R, gyro, accel, mag, field_nav)


def rms_error_deg(R_true: np.ndarray, q_est: np.ndarray, rows=slice(None)) -> np.ndarray:
    """RMS over rows of the roll, pitch, yaw of R_true^T R_est."""
    from rig.attitude.compare import error_rpy_deg
    from rig.rotations import matrix_from_quat

    err = error_rpy_deg(R_true[rows], matrix_from_quat(q_est[rows]))
    return np.sqrt(np.mean(err ** 2, axis=0))
