"""Hand sessions whose motions are quick for their sample rate, with the exact rotations they make.

A unit put down by hand in random attitudes. Each motion turns from one pose to the next along
`R0 exp(frac(s) v) exp(swing(s))`, s = (t - t0) / T: the hand's swing is a wobble of the rate axis (a cone of a few
degrees turning round at 2-4 Hz, zero at both ends), and the turn either eases in and out (a raised cosine) or is
set down abruptly: `frac' ~ s^2 (1 - s^q)` rises smoothly and drops to rest in the last tenth of the motion, a
corner in the rate where the unit meets the table. The motions start and end at any time, not on a sample, as a
hand's do. The gyro reads the exact body rate at each sample instant (a difference of the path over 1 us), so the
only error of an integration is the rate between samples it cannot see; the gravity at each pose is exact.

The truth's accelerometer H is upper triangular: its frame is the body frame, the one the turntable-free
calibration's gyro H maps into, so the gyro's H is compared with the truth entry by entry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

G = 9.81


@dataclass
class Motions:
    """How a session's hand moves: the duration of a motion, the largest turn, whether it sets the unit down
    abruptly (the exponent q of the stop; 0: eases in and out) and how far its axis wobbles."""

    seconds: tuple[float, float]
    max_turn_deg: float = 90.0
    stop_q: float = 0.0
    wobble_deg: float = 3.0


QUICK = Motions((0.8, 1.5), stop_q=10.0)          # 1.5-2.5 deg between samples at 100 Hz, set down abruptly
SLOW = Motions((2.0, 3.0))                         # 0.5-1 deg, eased


def hand_session(seed: int, motions: Motions, *, rate_hz: float = 100.0, poses: int = 20, rest_s: float = 10.0,
                 pose_s: tuple[float, float] = (3.0, 5.0), gyro_noise: float = 1e-4, accel_noise: float = 3e-3
                 ) -> dict:
    """t, accel (m/s^2), gyro (rad/s), the exact body rate and the truth's Ha, Ba, Hg, Bg of one session."""
    rng = np.random.default_rng(seed)
    attitudes = [Rotation.random(random_state=int(rng.integers(1 << 30)))]
    while len(attitudes) < poses:
        candidate = Rotation.random(random_state=int(rng.integers(1 << 30)))
        if np.degrees((attitudes[-1].inv() * candidate).magnitude()) < motions.max_turn_deg:
            attitudes.append(candidate)
    spans, start = [(0.0, rest_s, 0, None)], rest_s
    for k in range(1, poses):
        turn = (attitudes[k - 1].inv() * attitudes[k]).as_rotvec()
        across = np.cross(turn, rng.normal(size=3))
        e1 = across / np.linalg.norm(across)
        e2 = np.cross(turn / np.linalg.norm(turn), e1)
        shape = {"R0": attitudes[k - 1], "turn": turn, "e1": e1, "e2": e2, "T": rng.uniform(*motions.seconds),
                 "wobble": np.radians(motions.wobble_deg) * rng.uniform(0.5, 1.0), "hz": rng.uniform(2.0, 4.0),
                 "phase": rng.uniform(0.0, 2 * np.pi)}
        spans.append((start, shape["T"], k, shape))
        start += shape["T"]
        hold = rng.uniform(*pose_s)
        spans.append((start, hold, k, None))
        start += hold
    t = np.arange(int(start * rate_hz)) / rate_hz
    quat, rate = np.zeros((len(t), 4)), np.zeros((len(t), 3))
    for begin, duration, k, shape in spans:
        rows = (t >= begin) & (t < begin + duration)
        if shape is None:
            quat[rows] = attitudes[k].as_quat()
            continue
        s = (t[rows] - begin) / duration
        here, later = _path(s, shape, motions.stop_q), _path(s + 1e-6 / duration, shape, motions.stop_q)
        quat[rows] = here.as_quat()
        rate[rows] = (here.inv() * later).as_rotvec() / 1e-6
    force = Rotation.from_quat(quat).inv().apply([0.0, 0.0, G])
    Ha = np.eye(3) + np.triu(rng.normal(0, 0.01, (3, 3)))
    Hg = np.eye(3) + rng.normal(0, 0.01, (3, 3))
    Ba, Bg = rng.normal(0, 0.1, 3), rng.normal(0, 0.01, 3)
    accel = np.linalg.solve(Ha, force.T).T + Ba + rng.normal(0, accel_noise, force.shape)
    gyro = np.linalg.solve(Hg, rate.T).T + Bg + rng.normal(0, gyro_noise, rate.shape)
    return {"t": t, "accel": accel, "gyro": gyro, "rate": rate, "Ha": Ha, "Ba": Ba, "Hg": Hg, "Bg": Bg}


def _path(s: np.ndarray, shape: dict, stop_q: float) -> Rotation:
    if stop_q:
        q = stop_q
        frac = (s ** 3 / 3 - s ** (3 + q) / (3 + q)) / (1 / 3 - 1 / (3 + q))
    else:
        frac = s - np.sin(2 * np.pi * s) / (2 * np.pi)
    cone = 2 * np.pi * shape["hz"] * shape["T"] * s + shape["phase"]
    swing = shape["wobble"] * np.sin(np.pi * s)[:, None] ** 2 * (np.cos(cone)[:, None] * shape["e1"]
                                                                 + np.sin(cone)[:, None] * shape["e2"])
    return shape["R0"] * Rotation.from_rotvec(frac[:, None] * shape["turn"]) * Rotation.from_rotvec(swing)
