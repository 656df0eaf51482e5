"""A dynamic trajectory for attitude validation: a hold, continuous motion on both axes, a hold.

The reference is the table's encoders, read with their velocities every couple of ticks and joined by
cubic Hermite interpolation, so it stays accurate through the rate ramps (linear interpolation of 10 Hz
polls would be off by ~0.4 deg at 300 deg/s^2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procedures.acquisition import Sampler, grid_rate_hz
from procedures.move_and_hold import HOLD_POLL_S, MotionSettings, arm_table, position_table
from rig.schedule import Orientation
from procedures.reference import interpolate_angles
from rig.clock import Clock
from rig.rotations import TableGeometry, quat_from_matrix
from rig.session_data import SessionData

# (outer rate deg/s, inner rate deg/s, seconds): swings that return near the start, up to ~130 deg/s
DEFAULT_SEGMENTS = [(60.0, 130.0, 1.2), (-60.0, -130.0, 2.4), (60.0, 130.0, 1.2),
                    (-90.0, 70.0, 1.0), (90.0, -70.0, 2.0), (-90.0, 70.0, 1.0)]


@dataclass
class TrajectorySettings:
    start: Orientation = Orientation(35.0, 20.0)
    segments: tuple = tuple(DEFAULT_SEGMENTS)
    hold_s: float = 3.0
    accel_dps2: float = 300.0
    poll_every: int = 2


def run_trajectory(table, board, clock: Clock, geometry: TableGeometry, m: MotionSettings,
                   ts: TrajectorySettings | None = None) -> SessionData:
    """Record hold 0, the motion (phase 'move', step 0) and hold 1; returns the session arrays."""
    ts = ts or TrajectorySettings()
    arm_table(table, m)
    position_table(table, clock, ts.start, m)
    sampler = Sampler(board, clock, grid_rate_hz(board, m.schedule.rate_hz), m.schedule.mag_every)
    sampler.align_to("gyro")
    ref_t, ref_pos, ref_vel = [], [], []

    def poll() -> tuple[float, float]:
        sts = sorted((table.axis_status(a) for a in (0, 1)), key=lambda s: s.axis)
        ref_t.append(sampler.stamp(clock.now()))
        ref_pos.append([s.position_deg for s in sts])
        ref_vel.append([s.velocity_dps for s in sts])
        return ref_vel[-1]

    hold_ticks = int(round(ts.hold_s * sampler.rate_hz))
    chunk = max(int(round(HOLD_POLL_S * sampler.rate_hz)), 1)

    def hold() -> int:
        """Sample a hold, reading the encoders every HOLD_POLL_S (reference, and the watchdog's keep-alive);
        returns the rows it recorded."""
        r0 = sampler.rows
        for k in range(0, hold_ticks, chunk):
            sampler.run(min(chunk, hold_ticks - k))
            poll()
        return sampler.rows - r0

    phases = []
    poll()
    phases.append(("hold", 0, hold()))
    r0 = sampler.rows
    for rate_outer, rate_inner, seconds in ts.segments:
        table.move_velocity(0, rate_outer, ts.accel_dps2)
        table.move_velocity(1, rate_inner, ts.accel_dps2)
        for _ in range(int(round(seconds * sampler.rate_hz / ts.poll_every))):
            poll()
            sampler.run(ts.poll_every)
    table.stop()
    while True:
        vel = poll()
        sampler.run(ts.poll_every)
        if max(abs(v) for v in vel) == 0.0:
            break
    for _ in range(max(int(round(m.table.settle_s * sampler.rate_hz / ts.poll_every)), 1)):
        sampler.run(ts.poll_every)
        poll()
    phases.append(("move", 0, sampler.rows - r0))
    poll()
    phases.append(("hold", 1, hold()))
    rec = sampler.take()
    table.make_safe()
    return _session(rec, phases, np.array(ref_t), np.array(ref_pos), np.array(ref_vel), geometry, sampler.rate_hz,
                    sampler.t0)


def _session(rec, phases, ref_t, ref_pos, ref_vel, geometry, rate_hz: float, sampler_t0: float) -> SessionData:
    is_move = np.zeros(rec.t.size, bool)
    step = np.zeros(rec.t.size, int)
    k = 0
    for phase, j, n in phases:
        is_move[k:k + n] = phase == "move"
        step[k:k + n] = j
        k += n
    angles = interpolate_angles(rec.t, ref_t, ref_pos, ref_vel)
    q = quat_from_matrix(geometry.rotation(angles[:, 0], angles[:, 1]))
    cols = {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]}
    return SessionData(t=rec.t - rec.t[0], is_move=is_move, step=step, q_ref=q, raw=rec.samples,
                       columns={n: cols[n] for n in rec.samples}, sample_rate_hz=rate_hz, table_deg=angles,
                       temp_c=rec.temp_c, vsupply_v=rec.vsupply_v, source="<trajectory>",
                       meta={"clock_t0": float(rec.t[0]) + sampler_t0})
