"""A unit turned slowly in the hand and never set down, written from the physics (not from the fitting code).

The attitude follows a smooth random angular rate (a few sinusoids per axis, `rate_rad_s` RMS). The hand turns it
about the wrist, `lever_m` from the sensor, so the sensor is accelerated by `alpha x r + omega x (omega x r)`,
and the arm wanders: a linear acceleration in the world frame that is coloured noise (an Ornstein-Uhlenbeck
process of `wander_mps2` RMS and `wander_s` correlation time). The accelerometer reads the specific force
`f = R^T (a + g up)` through an upper-triangular H (the frame it defines, imu_tk's convention) and an offset, with
white noise; `mag_synth.readings` turns the same attitudes into a magnetometer's samples.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

GRAVITY = 9.80665


def smooth_rates(rng: np.random.Generator, t: np.ndarray, rate_rad_s: float) -> np.ndarray:
    """A body angular rate (n, 3) of a few slow sinusoids per axis, scaled to `rate_rad_s` RMS."""
    omega = np.zeros((len(t), 3))
    for axis in range(3):
        for _ in range(3):
            f = rng.uniform(0.03, 0.25)
            omega[:, axis] += rng.uniform(0.3, 1.0) * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    return omega * rate_rad_s / np.sqrt(np.mean(np.sum(omega ** 2, axis=1)))


def wander(rng: np.random.Generator, n: int, dt: float, sd: float, tau_s: float) -> np.ndarray:
    """(n, 3) Ornstein-Uhlenbeck acceleration of standard deviation `sd` and correlation time `tau_s`."""
    phi = np.exp(-dt / tau_s)
    kick = rng.normal(0.0, sd * np.sqrt(1.0 - phi * phi), (n, 3))
    out = np.empty((n, 3))
    out[0] = rng.normal(0.0, sd, 3)
    for k in range(1, n):
        out[k] = phi * out[k - 1] + kick[k]
    return out


def slow_sweep(seed: int, *, seconds: float = 120.0, rate_hz: float = 100.0, rate_rad_s: float = 0.5,
               lever_m: float = 0.12, wander_mps2: float = 0.05, wander_s: float = 0.4,
               accel_noise: float = 0.02) -> dict:
    """t, attitudes R (fixture -> world, (n, 3, 3)), raw accelerometer rows (m/s^2 before its H and B), the
    truth Ha (upper triangular) and Ba, and the specific force f the accelerometer felt."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    t = np.arange(int(seconds * rate_hz)) * dt
    omega = smooth_rates(rng, t, rate_rad_s)
    steps = Rotation.from_rotvec(omega[:-1] * dt)
    R = [Rotation.random(random_state=int(rng.integers(1 << 30)))]
    for s in steps:
        R.append(R[-1] * s)
    R = Rotation.concatenate(R).as_matrix()
    alpha = np.gradient(omega, dt, axis=0)
    lever = rng.normal(0.0, 1.0, 3)
    lever *= lever_m / np.linalg.norm(lever)
    turning = np.cross(alpha, lever) + np.cross(omega, np.cross(omega, lever))           # body frame
    arm = np.einsum("nji,nj->ni", R, wander(rng, len(t), dt, wander_mps2, wander_s))     # world -> body
    f = np.einsum("nji,j->ni", R, [0.0, 0.0, GRAVITY]) + turning + arm
    Ha = np.diag(rng.uniform(0.97, 1.03, 3)) + np.triu(rng.uniform(-0.01, 0.01, (3, 3)), 1)
    Ba = rng.uniform(-0.3, 0.3, 3)
    accel = np.linalg.solve(Ha, f.T).T + Ba + rng.normal(0.0, accel_noise, f.shape)
    return {"t": t, "R": R, "accel": accel, "Ha": Ha, "Ba": Ba, "f": f, "rng": rng}
