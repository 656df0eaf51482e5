"""A magnetometer stream for the synthetic recordings, written from the physics (not from the fitting code).

The Earth field in the world frame (x north, z up: a field of `field_uT` dipping `inclination_deg` below the
horizon) is turned into the fixture frame as gravity is, `u = R^T m`; the sensor reads `y = inv(H) u + B + noise`
(hard iron B, soft iron H, as calibration-json.md's `u = H (y - B)` undoes it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FIELD_UT = 48.0
INCLINATION_DEG = 60.0


@dataclass
class MagTruth:
    H: np.ndarray           # uT per raw unit
    B: np.ndarray           # raw units
    field_uT: float


def world_field(field_uT: float = FIELD_UT, inclination_deg: float = INCLINATION_DEG) -> np.ndarray:
    i = np.radians(inclination_deg)
    return field_uT * np.array([np.cos(i), 0.0, -np.sin(i)])


def mag_truth(rng: np.random.Generator, *, per_uT: float = 1.0, field_uT: float = FIELD_UT) -> MagTruth:
    """Soft iron within a few percent of the identity (scale and cross-talk), hard iron up to 40 uT; `per_uT` raw
    units per uT (0.01: gauss, 1000: nT, about 6.7: an LSB of 0.15 uT)."""
    H = (np.eye(3) + np.diag(rng.uniform(-0.06, 0.06, 3)) + rng.uniform(-0.03, 0.03, (3, 3)) * (1 - np.eye(3)))
    B = rng.uniform(-40.0, 40.0, 3)
    return MagTruth(H / per_uT, B * per_uT, field_uT)


def readings(R: np.ndarray, truth: MagTruth, rng: np.random.Generator, *, noise_uT: float = 0.3,
             inclination_deg: float = INCLINATION_DEG, per_row_field: np.ndarray | None = None) -> np.ndarray:
    """Raw magnetometer rows for fixture -> world attitudes R (n, 3, 3); `per_row_field` (n,) scales the field of
    each row (a pose beside a steel bench)."""
    u = np.einsum("nji,j->ni", R, world_field(truth.field_uT, inclination_deg))
    if per_row_field is not None:
        u = u * per_row_field[:, None]
    y = u @ np.linalg.inv(truth.H).T + truth.B
    return y + rng.normal(0.0, noise_uT, y.shape) @ np.linalg.inv(truth.H).T
