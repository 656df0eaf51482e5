"""A synthetic measured session with known truth, for the io/pipeline tests and the benchmark.

The table follows trapezoidal moves (fixtures.motion.TableTrack) between hold orientations
R = Rx(outer) @ Rz(inner) (conventions.md); the sensors read y = H^-1 u + B + noise, rounded to
integer counts, with u the specific force R^T (0, 0, G), the body rate, and the field R^T m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fixtures.motion import TableTrack
from rig.rotations import TableGeometry, quat_from_matrix
from rig.session_data import SessionData

GRAVITY = 9.80665
FIELD_UT = 48.0
DIP_DEG = 60.0


@dataclass
class Truth:
    H: dict[str, np.ndarray]
    B: dict[str, np.ndarray]
    schedule_deg: np.ndarray   # (k, 2) outer, inner


def default_schedule(n_holds: int = 20) -> np.ndarray:
    """Tumble schedule: outer tilts with inner turns, so gravity and field sweep the whole sphere."""
    outer = np.array([0, 45, 90, 135, 180, 225, 270, 315] * 3, dtype=float)[:n_holds]
    inner = (np.arange(n_holds) * 67.0) % 360.0
    return np.column_stack([outer, inner])


def truth_matrices(rng: np.random.Generator) -> Truth:
    def counts_per_unit(scale: list[float], mis: float) -> np.ndarray:
        return np.diag(scale) @ (np.eye(3) + mis * rng.standard_normal((3, 3)))

    K = {"accel": counts_per_unit([1670.0, 1650.0, 1690.0], 0.01),
         "gyro": counts_per_unit([939.7, 950.2, 930.1], 0.01),
         "mag": counts_per_unit([6.7, 6.5, 6.9], 0.03)}
    B = {"accel": np.array([120.0, -80.0, 200.0]), "gyro": np.array([15.0, -22.0, 7.0]),
         "mag": np.array([300.0, -200.0, 150.0])}
    return Truth(H={k: np.linalg.inv(v) for k, v in K.items()}, B=B, schedule_deg=np.empty((0, 2)))


def build_session(seed: int = 1, *, schedule_deg: np.ndarray | None = None, hold_s: float = 3.0,
                  rate_hz: float = 100.0, sensors: tuple[str, ...] = ("accel", "gyro", "mag"),
                  noise_counts: dict[str, float] | None = None, vmax_dps: float = 90.0,
                  accel_dps2: float = 180.0) -> tuple[SessionData, Truth]:
    rng = np.random.default_rng(seed)
    truth = truth_matrices(rng)
    schedule = default_schedule() if schedule_deg is None else np.asarray(schedule_deg, dtype=float)
    truth.schedule_deg = schedule
    noise = {"accel": 2.0, "gyro": 1.0, "mag": 1.5, **(noise_counts or {})}

    track = TableTrack(*schedule[0])
    bounds = []                          # (hold start, hold end) per step
    t_now = 0.0
    for k in range(len(schedule)):
        if k:
            arrive = [track.axes[a].move_to(t_now, schedule[k, a], vmax_dps, accel_dps2) for a in (0, 1)]
            t_now = max(arrive)
        bounds.append((t_now, t_now + hold_s))
        t_now += hold_s
    t = np.arange(0.0, t_now, 1.0 / rate_hz)
    starts = np.array([b[0] for b in bounds])
    step = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, None)
    is_move = t >= np.array([b[1] for b in bounds])[step]

    angles, rates, _ = track.angles(t)
    geometry = TableGeometry()
    R = geometry.rotation(angles[:, 0], angles[:, 1])
    omega = geometry.body_rate(angles[:, 0], angles[:, 1], rates[:, 0], rates[:, 1])
    dip = np.radians(DIP_DEG)
    world = {"accel": np.array([0.0, 0.0, GRAVITY]),
             "mag": FIELD_UT * np.array([np.cos(dip), 0.0, -np.sin(dip)])}
    raw = {}
    for name in sensors:
        u = omega if name == "gyro" else np.einsum("nji,j->ni", R, world[name])
        y = u @ np.linalg.inv(truth.H[name]).T + truth.B[name] + noise[name] * rng.standard_normal(u.shape)
        y = np.round(y)
        if name == "mag":
            y[1::2] = np.nan            # 50 Hz beside the 100 Hz accel/gyro
        raw[name] = y
    columns = {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]}
    session = SessionData(
        t=t, is_move=is_move, step=step, q_ref=quat_from_matrix(R), raw=raw,
        columns={k: columns[k] for k in sensors}, gravity=GRAVITY,
        field_uT=FIELD_UT if "mag" in sensors else None, sample_rate_hz=rate_hz, table_deg=angles.copy(),
        temp_c=25.0 + 0.01 * t, vsupply_v=np.full_like(t, 3.3),
        meta={"table": {"outer_axis_world": [1, 0, 0], "inner_axis_fixture": [0, 0, 1]}, "operator": "synthetic"})
    return session, truth
