"""A small simulated session with known B and H for accel, gyro and mag (seeded, optionally noise-free).

Raw counts are `y = H^-1 u + B` (the inverse of `u = H (y - B)`), with `u` the fixture-frame specific
force R^T (0, 0, G), field R^T m, and for moves the body rate of a table whose encoder angles change
smoothly (cosine profile). Holds 1 s, moves 2 s, 100 Hz; the magnetometer has every other row empty.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.rotations import TableGeometry, quat_from_matrix
from rig.session_data import SessionData

G, M = 9.80665, 48.0
INCLINATION_DEG = 60.0
RATE_HZ, HOLD_S, MOVE_S = 100.0, 1.0, 2.0
ORIENTATIONS = [(0, 0), (90, 0), (90, 90), (180, 90), (180, 180), (270, 180), (270, 270), (45, 270),
                (45, 30), (135, 30), (135, 120), (225, 120)]

TRUE = {
    "accel": {"B": np.array([120.0, -80.0, 40.0]),
              "H": np.array([[2.4e-3, 2.0e-5, -1.0e-5], [0.0, 2.5e-3, 3.0e-5], [1.0e-5, -2.0e-5, 2.3e-3]])},
    "gyro": {"B": np.array([15.0, -9.0, 4.0]),
             "H": np.array([[1.5e-4, 1.0e-6, 0.0], [-2.0e-6, 1.52e-4, 1.0e-6], [0.0, 2.0e-6, 1.49e-4]])},
    "mag": {"B": np.array([300.0, -150.0, 90.0]),
            "H": np.array([[0.15, 0.004, 0.0], [0.002, 0.16, -0.003], [0.0, 0.001, 0.14]])},
}
FIELD_WORLD = M * np.array([np.cos(np.radians(INCLINATION_DEG)), 0.0, -np.sin(np.radians(INCLINATION_DEG))])


def truth_dict() -> dict:
    return {"sensors": {s: {"B": p["B"].tolist(), "H": p["H"].tolist()} for s, p in TRUE.items()}}


def true_calibrations() -> dict[str, TriadCalibration]:
    return {s: TriadCalibration(B=p["B"].copy(), H=p["H"].copy(), method="truth", residual_rms=0.0)
            for s, p in TRUE.items()}


def _raw(sensor: str, u: np.ndarray) -> np.ndarray:
    p = TRUE[sensor]
    return u @ np.linalg.inv(p["H"]).T + p["B"]


def make_session(noise: float = 0.0, seed: int = 0) -> SessionData:
    """Holds at ORIENTATIONS joined by recorded moves; `noise` = raw-count noise std of every sensor."""
    rng = np.random.default_rng(seed)
    geo = TableGeometry()
    blocks = []
    t0 = 0.0
    for j, (a, b) in enumerate(ORIENTATIONS):
        n = int(HOLD_S * RATE_HZ)
        t_hold = t0 + np.arange(n) / RATE_HZ
        angles = np.tile([a, b], (n, 1)).astype(float)
        blocks.append(_block(t_hold, False, j, angles, np.zeros((n, 3)), geo.rotation(a, b)))
        if j + 1 < len(ORIENTATIONS):
            # cosine profile: the table starts and stops smoothly, at rest on the hold samples around it
            a1, b1 = ORIENTATIONS[j + 1]
            tau = np.arange(1, int(MOVE_S * RATE_HZ)) / RATE_HZ
            s = 0.5 * (1.0 - np.cos(np.pi * tau / MOVE_S))
            s_dot = 0.5 * np.pi / MOVE_S * np.sin(np.pi * tau / MOVE_S)
            ang = np.column_stack([a + (a1 - a) * s, b + (b1 - b) * s])
            rate = geo.body_rate(ang[:, 0], ang[:, 1], (a1 - a) * s_dot, (b1 - b) * s_dot)
            blocks.append(_block(t_hold[-1] + tau, True, j, ang, rate, geo.rotation(ang[:, 0], ang[:, 1])))
        t0 = t_hold[-1] + MOVE_S
    t = np.concatenate([bl["t"] for bl in blocks])
    raw = {s: np.concatenate([bl[s] for bl in blocks]) for s in TRUE}
    for s in raw:
        raw[s] = raw[s] + rng.normal(0.0, noise, raw[s].shape) if noise else raw[s]
    return SessionData(t=t, is_move=np.concatenate([bl["is_move"] for bl in blocks]),
                       step=np.concatenate([bl["step"] for bl in blocks]),
                       q_ref=np.concatenate([bl["q"] for bl in blocks]), raw=raw,
                       columns={"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]},
                       gravity=G, field_uT=M, sample_rate_hz=RATE_HZ,
                       table_deg=np.concatenate([bl["angles"] for bl in blocks]),
                       meta={"unit_serial": "SIM-7", "operator": "test | pipe"}, source="<synthetic>")


def _block(t, is_move: bool, step: int, angles, rate, R) -> dict:
    n = len(t)
    R = np.broadcast_to(R, (n, 3, 3))
    accel = _raw("accel", np.einsum("kji,j->ki", R, [0.0, 0.0, G]))
    mag = _raw("mag", np.einsum("kji,j->ki", R, FIELD_WORLD))
    mag[1::2] = np.nan
    return {"t": t, "is_move": np.full(n, is_move), "step": np.full(n, step), "angles": angles,
            "q": quat_from_matrix(R), "accel": accel, "gyro": _raw("gyro", rate), "mag": mag}
