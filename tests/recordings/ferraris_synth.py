"""A hand-made Ferraris session with a known truth, written only from the protocol (not from the fitting code).

Six faces put down by hand (each tilted from its nominal attitude by a random angle of the given size), the
motions between them (smooth turns about a fixed axis), then one turn about each sensor axis whose axis wobbles
and whose angle misses 360 deg by a little, as a hand does. The sensor reads `y = inv(H) u + B + noise`, rounded
to counts. The result is an imported-style recording (reference none, static and rotation segments).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.io.recording import recording_session
from mag_synth import MagTruth, mag_truth, readings
from rig.rotations import axis_angle_matrix, rotvec_from_matrix
from rig.session_data import SessionData

G = 9.80665
FACES = {"x_p": (1, 0, 0), "x_a": (-1, 0, 0), "y_p": (0, 1, 0), "y_a": (0, -1, 0), "z_p": (0, 0, 1), "z_a": (0, 0, -1)}


@dataclass
class Truth:
    accel_H: np.ndarray       # m/s^2 per count
    accel_B: np.ndarray       # counts
    gyro_H: np.ndarray        # rad/s per count
    gyro_B: np.ndarray
    face_tilt_deg: np.ndarray
    turn_angle_deg: np.ndarray
    mag: MagTruth | None = None


def attitude_with_up(up: np.ndarray) -> np.ndarray:
    """A fixture -> world rotation that puts the sensor axis `up` along world +z."""
    up = np.asarray(up, float)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(up, z)
    if np.linalg.norm(axis) < 1e-9:
        return np.eye(3) if up @ z > 0 else axis_angle_matrix(np.array([1.0, 0, 0]), np.pi)
    angle = np.arccos(np.clip(up @ z, -1, 1))
    return axis_angle_matrix(axis / np.linalg.norm(axis), angle)


def generate(seed: int = 0, *, rate_hz: float = 100.0, tilt_deg: float = 1.5, turn_err_deg: float = 1.5,
             wobble_deg: float = 1.0, accel_noise: float = 1.0, gyro_noise: float = 1.0,
             face_s: float = 5.0, move_s: float = 2.0, shake_deg: float = 0.0,
             shake_hz: float = 2.0, mag_per_uT: float | None = None,
             motion_scale_sd: float = 0.0) -> tuple[SessionData, Truth]:
    """`shake_deg`: the motions between faces also swing by up to this angle about an axis that turns round at
    `shake_hz` (a hand's motion, whose rate axis never stays put), starting and ending still. `mag_per_uT`: add a
    magnetometer in these raw units per uT (`mag_synth`; 1.0 for a column in uT), drawn after everything else so
    the accelerometer and gyro are those of the same seed without it. `motion_scale_sd`: the gyro reads each motion
    between faces at its own scale, off by a fraction of this standard deviation (a fast flip's angle comes out
    wrong, its axis does not), drawn from a stream of its own so the rest of the seed is unchanged."""
    rng = np.random.default_rng(seed)
    accel_H = (np.eye(3) + np.diag(rng.uniform(-0.03, 0.03, 3)) + rng.uniform(-0.01, 0.01, (3, 3)) * (1 - np.eye(3))) \
        * (G / 2048.0)
    gyro_H = (np.eye(3) + np.diag(rng.uniform(-0.03, 0.03, 3)) + rng.uniform(-0.01, 0.01, (3, 3)) * (1 - np.eye(3))) \
        * np.radians(1 / 16.4)
    accel_B, gyro_B = rng.uniform(-40, 40, 3), rng.uniform(-20, 20, 3)
    dt = 1.0 / rate_hz
    Rs, ws, segments, tilts = [], [], [], []
    t_now = 0.0

    def hold(R, seconds, name, up):
        nonlocal t_now
        n = int(round(seconds * rate_hz))
        Rs.extend([R] * n)
        ws.extend([np.zeros(3)] * n)
        segments.append({"name": name, "t0": t_now + dt, "t1": t_now + (n - 2) * dt, "kind": "static", "up": up,
                         "tilt_deg_sd": 2.0})
        t_now += n * dt

    def turn(R0, axis_fixture, angle, seconds):
        """Rotate about a fixture-frame axis with a smooth (raised cosine) rate; returns the end attitude."""
        nonlocal t_now
        n = int(round(seconds * rate_hz))
        s = np.arange(1, n + 1) / n
        frac = s - np.sin(2 * np.pi * s) / (2 * np.pi)
        rate = angle * (1 - np.cos(2 * np.pi * s)) / seconds
        for f, r in zip(frac, rate):
            Rs.append(R0 @ axis_angle_matrix(axis_fixture, angle * f))
            ws.append(axis_fixture * r)
        t_now += n * dt
        return Rs[-1]

    def shaken_turn(R0, v, seconds):
        """R0 exp(frac(s) v) exp(sin^2(pi s) shake u(s)), u turning round the plane across v; the body rate from the
        path itself (a difference over 1 us)."""
        nonlocal t_now
        n = int(round(seconds * rate_hz))
        e1 = _unit(np.cross(v, rng.normal(size=3)))
        e2 = _unit(np.cross(v, e1))
        amplitude = np.radians(shake_deg)

        def path(s):
            frac = s - np.sin(2 * np.pi * s) / (2 * np.pi)
            phase = 2 * np.pi * shake_hz * seconds * s
            swing = amplitude * np.sin(np.pi * s) ** 2 * (np.cos(phase) * e1 + np.sin(phase) * e2)
            return R0 @ _rotation(frac * v) @ _rotation(swing)

        eps = 1e-6 / seconds
        for s in np.arange(1, n + 1) / n:
            Rk = path(s)
            Rs.append(Rk)
            ws.append(rotvec_from_matrix(Rk.T @ path(s + eps)) / (eps * seconds))
        t_now += n * dt
        return Rs[-1]

    R, motions = None, []
    for name, up in FACES.items():
        tilt = axis_angle_matrix(_unit(rng.normal(size=3)), np.radians(tilt_deg) * abs(rng.normal()))
        target = tilt @ attitude_with_up(np.array(up, float))
        tilts.append(np.degrees(np.arccos(np.clip((target.T @ [0, 0, 1.0]) @ np.array(up, float), -1, 1))))
        if R is not None:
            v = rotvec_from_matrix(R.T @ target)
            start = len(ws)
            if shake_deg:
                shaken_turn(R, v, move_s)
            else:
                turn(R, v / np.linalg.norm(v), np.linalg.norm(v), move_s)
            motions.append(slice(start, len(ws)))
        R = target
        hold(R, face_s, name, ("+" if max(up) > 0 else "-") + "xyz"[int(np.argmax(np.abs(up)))])
    turn_angles = []
    for k, name in enumerate(("x_rot", "y_rot", "z_rot")):
        axis = np.eye(3)[k]
        wobble = axis_angle_matrix(_unit(np.cross(axis, rng.normal(size=3))), np.radians(wobble_deg))
        angle = np.radians(360.0 + rng.normal(0, turn_err_deg))
        turn_angles.append(np.degrees(angle))
        start = t_now
        R = turn(R, wobble @ axis, angle, 4.0)
        segments.append({"name": name, "t0": start, "t1": t_now - dt, "kind": "rotation", "axis": "+" + "xyz"[k],
                         "angle_deg": 360.0, "angle_deg_sd": 2.0})
        hold(R, 2.0, f"rest_{k}", None)
        segments.pop()
    Rs, ws = np.array(Rs), np.array(ws)
    read = ws.copy()
    for rows, off in zip(motions, np.random.default_rng([seed, 1]).normal(0.0, motion_scale_sd, len(motions))):
        read[rows] *= 1.0 + off
    t = np.arange(len(Rs)) * dt
    f = np.einsum("nji,j->ni", Rs, np.array([0.0, 0.0, G]))
    accel = np.round(f @ np.linalg.inv(accel_H).T + accel_B + rng.normal(0, accel_noise, f.shape))
    gyro = np.round(read @ np.linalg.inv(gyro_H).T + gyro_B + rng.normal(0, gyro_noise, ws.shape))
    raw, units, mag = {"accel": accel, "gyro": gyro}, {"accel": "counts", "gyro": "counts"}, None
    if mag_per_uT is not None:
        mag = mag_truth(rng, per_uT=mag_per_uT)
        raw["mag"], units["mag"] = readings(Rs, mag, rng), "uT" if mag_per_uT == 1.0 else "counts"
    session = recording_session(t, raw, units=units, field_uT=mag.field_uT if mag else None,
                                source=f"<synthetic ferraris {seed}>", segments=segments, sample_rate_hz=rate_hz)
    return session, Truth(accel_H, accel_B, gyro_H, gyro_B, np.array(tilts), np.array(turn_angles), mag)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _rotation(rotvec: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(rotvec))
    return np.eye(3) if angle == 0 else axis_angle_matrix(rotvec / angle, angle)
