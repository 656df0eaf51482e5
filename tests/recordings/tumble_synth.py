"""A unit turned by hand through every attitude, written from the physics (not from the fitting code): a smooth
random angular rate (a few sinusoids per axis, about a turn a second) integrated into attitudes, which
`mag_synth.readings` turns into raw magnetometer samples. `hemisphere` keeps the field's direction within a cap
of the sensor's sphere (a user who never turns the unit over)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def tumble(rng: np.random.Generator, *, seconds: float = 60.0, rate_hz: float = 50.0,
           rate_rad_s: float = 1.5) -> tuple[np.ndarray, np.ndarray]:
    """t (n,) and fixture -> world attitudes R (n, 3, 3) of a hand tumble."""
    t = np.arange(int(seconds * rate_hz)) / rate_hz
    omega = np.zeros((len(t), 3))
    for axis in range(3):
        for _ in range(3):
            f = rng.uniform(0.05, 0.4)
            omega[:, axis] += rng.uniform(0.3, 1.0) * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    omega *= rate_rad_s / np.sqrt(np.mean(np.sum(omega ** 2, axis=1)))
    steps = Rotation.from_rotvec(omega[:-1] / rate_hz)
    R = [Rotation.random(random_state=int(rng.integers(1 << 30)))]
    for s in steps:
        R.append(R[-1] * s)
    return t, Rotation.concatenate(R).as_matrix()


def level_turns(rng: np.random.Generator, *, tilt_deg: float, seconds: float = 60.0,
                rate_hz: float = 50.0) -> tuple[np.ndarray, np.ndarray]:
    """t and attitudes of a unit turned round and round on a table (heading through whole turns) and tilted
    by at most `tilt_deg` about its level axes: the field sweeps a band of the sensor's sphere, not all of it."""
    t = np.arange(int(seconds * rate_hz)) / rate_hz
    heading = 2 * np.pi * t / rng.uniform(8.0, 15.0)
    tilts = [np.radians(tilt_deg) * np.sin(2 * np.pi * t / rng.uniform(3.0, 9.0) + rng.uniform(0, 2 * np.pi))
             for _ in range(2)]
    R = Rotation.from_euler("ZYX", np.column_stack([heading, tilts[0], tilts[1]]))
    return t, R.as_matrix()
