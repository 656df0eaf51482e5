"""Synthetic accelerometer/magnetometer truths and holds for the vector-calibration tests."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

G = 9.80665
M_FIELD = 50.0


@dataclass
class Truth:
    H: np.ndarray
    B: np.ndarray
    v: np.ndarray          # reference in the world frame
    norm: float

    def holds(self, R: np.ndarray, noise: float, rng: np.random.Generator) -> np.ndarray:
        x = np.einsum("kji,j->ki", R, self.v)
        return x @ np.linalg.inv(self.H).T + self.B + noise * rng.standard_normal(x.shape)


def accel_truth(rng: np.random.Generator) -> Truth:
    """~400 counts per m/s^2, B ~ 2000 counts, +-3 % scale, 2 % cross-axis, 3 deg mounting rotation."""
    S = np.diag(400.0 * (1 + 0.03 * rng.uniform(-1, 1, 3)))
    C = np.eye(3) + 0.02 * np.triu(rng.standard_normal((3, 3)), 1)
    Q = Rotation.from_rotvec(np.radians(3.0) * rng.standard_normal(3)).as_matrix()
    B = rng.choice([-1, 1], 3) * rng.uniform(1500, 2500, 3)
    return Truth(H=np.linalg.inv(Q @ C @ S), B=B, v=np.array([0.0, 0.0, G]), norm=G)


def mag_truth(rng: np.random.Generator) -> Truth:
    """~10 counts per uT, soft iron 5 %, hard iron ~300 counts, field 50 uT pointing down (dip 60 deg)."""
    K = 10.0 * (np.eye(3) + 0.05 * rng.standard_normal((3, 3)))
    B = rng.uniform(-400, 400, 3)
    dip, dec = np.radians(60.0), rng.uniform(0, 2 * np.pi)
    v = M_FIELD * np.array([np.cos(dip) * np.cos(dec), np.cos(dip) * np.sin(dec), -np.sin(dip)])
    return Truth(H=np.linalg.inv(K), B=B, v=v, norm=M_FIELD)


def random_rotations(n: int, rng: np.random.Generator) -> np.ndarray:
    return Rotation.random(n, random_state=rng).as_matrix()


def h_error(H_est: np.ndarray, H: np.ndarray) -> float:
    return float(np.linalg.norm(H_est - H) / np.linalg.norm(H))
