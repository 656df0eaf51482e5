"""A hand-held recording in SI units (accelerometer m/s^2, gyro rad/s, magnetometer uT) written from the physics,
for the hidden-effect tests of the twin's causes: random poses held by hand and turned between, at a sample rate of
the user's choice. What a real hand adds can be switched on, each by its own law and never through the analysis's
code:

- `lever_m`: the sensor sits that far from the point the hand turns about (along a fixed body direction): during
  the motions the accelerometer also reads the point's tangential and centripetal acceleration;
- `tremor_dps`: the hand turns the unit a little during the holds (a rotation: the gyro reads its rate, the
  accelerometer sees gravity turn with it), an RMS rate in deg/s of a band-limited process;
- `vibration`: (RMS m/s^2, low Hz, high Hz) a linear acceleration of the holds in that band (a motor, a fan, a
  vehicle), which the gyro does not see;
- `gyro_lag_s`: the gyro's stream late against the accelerometer's (a logger that reads two chips in turn), and
  `mag_lag_s` the magnetometer's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.spatial.transform import Rotation

G = 9.81
FIELD_WORLD_UT = 48.0 * np.array([np.cos(np.radians(60.0)), 0.0, -np.sin(np.radians(60.0))])


@dataclass
class Hand:
    """What the generator put in, for the test to compare the analysis with."""

    t: np.ndarray
    accel: np.ndarray
    gyro: np.ndarray
    mag: np.ndarray | None
    pose: np.ndarray                       # pose index of every row, -1 in a motion
    truth: dict = field(default_factory=dict)


def band_noise(rng: np.random.Generator, n: int, rate: float, low_hz: float, high_hz: float) -> np.ndarray:
    """(n, 3) Gaussian noise of unit RMS per axis in the band [low_hz, high_hz] (zero-phase Butterworth)."""
    nyquist = 0.5 * rate
    if low_hz > 0:
        sos = butter(4, [low_hz / nyquist, min(high_hz / nyquist, 0.99)], btype="band", output="sos")
    else:
        sos = butter(4, min(high_hz / nyquist, 0.99), output="sos")
    x = sosfiltfilt(sos, rng.standard_normal((n + 400, 3)), axis=0)[200:-200]
    return x / x.std(axis=0)


def hand_recording(seed: int, *, rate: float = 100.0, poses: int = 16, rest_s: float = 20.0,
                   pose_s: tuple[float, float] = (4.0, 6.0), move_s: tuple[float, float] = (1.5, 2.5),
                   accel_noise: float = 0.01, gyro_noise: float = 0.003, mag_noise: float = 0.3,
                   lever_m: float = 0.0, tremor_dps: float = 0.0, tremor_band_hz: tuple[float, float] = (0.2, 3.0),
                   vibration: tuple[float, float, float] | None = None, gyro_lag_s: float = 0.0,
                   mag_lag_s: float = 0.0, with_mag: bool = False, first_pose_still: bool = True) -> Hand:
    """One hand-held session: a rest, then `poses - 1` more poses each reached by a smooth turn. The disturbances
    of the holds spare the first pose (the rest) when `first_pose_still`, as a user sets the unit down first."""
    rng = np.random.default_rng(seed)
    attitudes = [Rotation.random(random_state=int(rng.integers(1 << 30))) for _ in range(poses)]
    spans = [(rest_s, 0, None)]
    for k in range(1, poses):
        spans += [(rng.uniform(*move_s), None, k), (rng.uniform(*pose_s), k, None)]
    t = np.arange(int(sum(s[0] for s in spans) * rate)) / rate
    n = len(t)
    quat, omega, alpha = np.zeros((n, 4)), np.zeros((n, 3)), np.zeros((n, 3))
    pose = np.full(n, -1)
    start = 0.0
    for duration, still, moving_to in spans:
        rows = (t >= start) & (t < start + duration)
        if still is not None:
            quat[rows], pose[rows] = attitudes[still].as_quat(), still
        else:
            turn = (attitudes[moving_to - 1].inv() * attitudes[moving_to]).as_rotvec()
            s = (t[rows] - start) / duration
            quat[rows] = (attitudes[moving_to - 1] * Rotation.from_rotvec(np.outer(10 * s**3 - 15 * s**4 + 6 * s**5,
                                                                                    turn))).as_quat()
            omega[rows] = np.outer(30 * s**2 * (1 - s) ** 2 / duration, turn)       # about a fixed body axis
            alpha[rows] = np.outer(60 * s * (1 - s) * (1 - 2 * s) / duration**2, turn)
        start += duration
    R = Rotation.from_quat(quat)
    held = (pose >= 0) & ~((pose == 0) & first_pose_still)
    truth: dict = {"gyro_lag_s": gyro_lag_s, "mag_lag_s": mag_lag_s}
    if tremor_dps > 0:
        angle = band_noise(rng, n, rate, *tremor_band_hz)
        angle[~held] = 0.0
        for p in np.unique(pose[held]):                      # each hold's tilt starts and ends where the pose is
            rows = np.flatnonzero(pose == p)
            edge = np.minimum(np.arange(len(rows)), np.arange(len(rows))[::-1]) / (0.5 * rate)
            angle[rows] -= angle[rows].mean(axis=0)
            angle[rows] *= (0.5 - 0.5 * np.cos(np.pi * np.minimum(edge, 1.0)))[:, None]
        rate_noise = np.gradient(angle, 1.0 / rate, axis=0)
        gain = np.radians(tremor_dps) / np.sqrt(np.mean(np.sum(rate_noise[held] ** 2, axis=1)))
        angle, rate_noise = angle * gain, rate_noise * gain
        R = R * Rotation.from_rotvec(angle)
        omega = omega + rate_noise
        truth["tremor_rms_dps"] = float(tremor_dps)
    force = R.inv().apply([0.0, 0.0, G])
    if lever_m > 0:
        r = rng.normal(size=3)
        r *= lever_m / np.linalg.norm(r)
        force = force + np.cross(alpha, r) + np.cross(omega, np.cross(omega, r))
        truth["lever_m"] = r.tolist()
    if vibration is not None:
        rms, low, high = vibration
        shake = band_noise(rng, n, rate, low, high) * rms / np.sqrt(3)
        shake[~held] = 0.0
        force = force + shake
        truth["vibration_rms_mps2"] = float(np.sqrt(np.mean(np.sum(shake[held] ** 2, axis=1))))
    Ha, Hg = np.eye(3) + rng.normal(0, 0.01, (3, 3)), np.eye(3) + rng.normal(0, 0.01, (3, 3))
    Ba, Bg = rng.normal(0, 0.1, 3), rng.normal(0, 0.01, 3)
    accel = np.linalg.solve(Ha, force.T).T + Ba + rng.normal(0, accel_noise, (n, 3))
    gyro_true = _late(t, omega, gyro_lag_s)
    gyro = np.linalg.solve(Hg, gyro_true.T).T + Bg + rng.normal(0, gyro_noise, (n, 3))
    mag = None
    if with_mag:
        field_body = _late(t, R.inv().apply(FIELD_WORLD_UT), mag_lag_s)
        Hm = np.eye(3) + rng.normal(0, 0.02, (3, 3))
        mag = np.linalg.solve(Hm, field_body.T).T + rng.uniform(-20, 20, 3) + rng.normal(0, mag_noise, (n, 3))
    return Hand(t, accel, gyro, mag, pose, truth)


def _late(t: np.ndarray, x: np.ndarray, lag_s: float) -> np.ndarray:
    """x read `lag_s` late: the value at t is the truth of t - lag_s."""
    if not lag_s:
        return x
    return np.stack([np.interp(t - lag_s, t, x[:, k]) for k in range(3)], axis=1)


def hand_session(hand: Hand, *, rest_s: float = 20.0, source: str = "<hand>"):
    """The recording as `rig import csv ... --units accel=m/s^2,gyro=rad/s[,mag=uT] --initial-rest-s` reads it."""
    from rig.io.recording import recording_session

    raw = {"accel": hand.accel, "gyro": hand.gyro}
    units = {"accel": "m/s^2", "gyro": "rad/s"}
    if hand.mag is not None:
        raw["mag"], units["mag"] = hand.mag, "uT"
    rate = 1.0 / float(np.median(np.diff(hand.t)))
    return recording_session(hand.t, raw, units=units, source=source, gravity=G,
                             field_uT=48.0 if hand.mag is not None else None, sample_rate_hz=rate,
                             initial_rest_s=rest_s)
