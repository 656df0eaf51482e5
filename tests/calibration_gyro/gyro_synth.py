"""Shared helpers of the gyro-calibration tests: seeded RNG fixture, errors, a hand-held record."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from rig.rotations import matrix_from_rotvec
from tests.paths import DATA

XSENS = DATA / "imu_tk-xsens"


@pytest.fixture
def rng(request) -> np.random.Generator:
    """A different, reproducible seed per test (CRC of the test's name)."""
    return np.random.default_rng(zlib.crc32(request.node.name.encode()))


def rel_err(H: np.ndarray, H_true: np.ndarray) -> float:
    return float(np.linalg.norm(H - H_true) / np.linalg.norm(H_true))


def handheld_record(rng: np.random.Generator, *, poses: int = 30, rate_hz: float = 100.0, gravity: float = 9.80665,
                    accel_noise: float = 0.01, gyro_noise: float = 0.003, vertical_turns: tuple[int, ...] = (),
                    tilt_deg: float = 0.0, rest_s: float = 50.0):
    """A hand-held multi-position record with its truth (imu_tk-like, no known rotations).

    The body frame is the accelerometer frame, so the true accelerometer H is upper triangular
    (unit-diagonal misalignment times scale); the gyro H is a full matrix into that frame.
    Starts with `rest_s` s at rest (0: with the first move); each move turns about a random body axis by 40-120 deg
    with a smooth (zero end-rate) profile, then rests 3-4 s. The moves numbered in `vertical_turns` (0 the first) turn
    about an axis `tilt_deg` from the vertical instead: gravity moves that little in the body, and the accelerometer
    barely sees them.
    """
    Ha = np.triu(rng.normal(0, 0.01, (3, 3)), 1) + np.eye(3)
    Ha = Ha @ np.diag(1.0 / rng.uniform(400, 420, 3))
    Ba = rng.uniform(32000, 33500, 3)
    Hg = (np.eye(3) + rng.normal(0, 0.02, (3, 3))) @ np.diag(1.0 / rng.uniform(4700, 4800, 3))
    Bg = rng.uniform(32400, 32800, 3)
    dt = 1.0 / rate_hz
    R = matrix_from_rotvec(rng.normal(0, 1, 3))
    f_world = np.array([0.0, 0.0, gravity])
    fs, ws, rests = [], [], []

    def rest(seconds: float) -> None:
        n = int(round(seconds / dt))
        start = sum(len(f) for f in fs)
        rests.append((start, start + n - 1))
        fs.append(np.tile(R.T @ f_world, (n, 1)))
        ws.append(np.zeros((n, 3)))

    if rest_s > 0:
        rest(rest_s)
    for move in range(poses):
        axis = rng.normal(0, 1, 3)
        tilted = [np.sin(np.radians(tilt_deg)), 0.0, np.cos(np.radians(tilt_deg))]
        axis = R.T @ tilted if move in vertical_turns else axis / np.linalg.norm(axis)
        angle, T = np.radians(rng.uniform(40, 120)), rng.uniform(1.5, 3.0)
        tau = np.arange(0.0, T, dt) / T
        theta = angle * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi))
        rate = angle / T * (1 - np.cos(2 * np.pi * tau))
        Rs = R @ matrix_from_rotvec(np.outer(theta, axis))
        fs.append(np.einsum("nji,j->ni", Rs, f_world))
        ws.append(np.outer(rate, axis))
        R = R @ matrix_from_rotvec(axis * angle)
        rest(rng.uniform(3.0, 4.0))
    f, w = np.vstack(fs), np.vstack(ws)
    t = np.arange(len(f)) * dt
    accel = (f + rng.normal(0, accel_noise, f.shape)) @ np.linalg.inv(Ha).T + Ba
    gyro = (w + rng.normal(0, gyro_noise, w.shape)) @ np.linalg.inv(Hg).T + Bg
    return t, accel, gyro, {"Ha": Ha, "Ba": Ba, "Hg": Hg, "Bg": Bg, "poses": poses, "rests": rests}
