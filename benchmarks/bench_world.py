"""Benchmark: the simulated world's cost per sample, and 150 s of simulated rig time through the world and the
fake turntable (holds and moves of a 20-orientation session, the client polling over Modbus TCP on loopback).
Prints JSON."""

from __future__ import annotations

import json
import time

import numpy as np

from fixtures.motion import TableTrack
from fixtures.world import World, random_sensor_models
from fixtures.world.session_sim import SessionPlan, simulate_session
from rig.schedule import plan_orientations


def per_sample_us() -> dict:
    track = TableTrack()
    track.axes[0].move_to(0.0, 170.0, 60.0, 120.0)
    track.axes[1].move_to(0.0, -150.0, 60.0, 120.0)
    w = World(track, random_sensor_models(np.random.default_rng(0)))
    out = {}
    for name in ("accel", "gyro", "mag"):
        src = w.source(name)
        n = 20000
        t0 = time.perf_counter()
        for i in range(n):
            src.sense(i * 0.001)
        out[f"scalar_{name}_us"] = round((time.perf_counter() - t0) / n * 1e6, 2)
    t = np.arange(150000) * 0.001
    t0 = time.perf_counter()
    w.sense("gyro", t)
    out["vectorised_us"] = round((time.perf_counter() - t0) / t.size * 1e6, 3)
    return out


def world_and_turntable_150s() -> dict:
    """A session's worth of world samples (accel/gyro 100 Hz, mag 50 Hz) plus the client's move polling,
    on the fake turntable with a simulated clock; no drivers or buses."""
    from fixtures.turntable import FakeTurntable, TurntableServer
    from rig.clock import SimClock
    from rig.turntable import TurntableLink

    clock = SimClock()
    tt = FakeTurntable(clock, soft_limits=((-200.0, 200.0), (-200.0, 200.0)))
    world = World(tt.track, random_sensor_models(np.random.default_rng(1)), seed=1)
    sources = {n: world.source(n) for n in ("accel", "gyro", "mag")}
    schedule = plan_orientations(20)
    k = [0]

    def sample(dt):
        end = clock.now() + dt
        while clock.now() < end:
            clock.sleep(0.01)
            t = clock.now()
            sources["accel"].sense(t)
            sources["gyro"].sense(t)
            if k[0] % 2 == 0:
                sources["mag"].sense(t)
            k[0] += 1

    t0 = time.perf_counter()
    with TurntableServer(tt) as srv, TurntableLink(srv.url, clock=clock, poll_interval=0.1) as link:
        link.enable()
        for o in schedule:
            link.move_to(o.outer_deg, o.inner_deg, speed_dps=60, accel_dps2=120, settle_s=0.3, wait=sample)
            sample(5.0)
        link.make_safe()
    wall = time.perf_counter() - t0
    return {"rig_time_s": round(clock.now(), 1), "wall_s": round(wall, 3), "samples": k[0] * 2 + k[0] // 2,
            "target_wall_s_per_150s": 1.0, "wall_s_per_150s": round(wall * 150.0 / clock.now(), 3)}


def direct_session_ms() -> float:
    plan = SessionPlan([(o.outer_deg, o.inner_deg) for o in plan_orientations(20)])
    t0 = time.perf_counter()
    simulate_session(random_sensor_models(np.random.default_rng(2)), plan)
    return round((time.perf_counter() - t0) * 1e3, 1)


if __name__ == "__main__":
    print(json.dumps({"benchmark": "world", "per_sample": per_sample_us(),
                      "session_150s": world_and_turntable_150s(),
                      "direct_vectorised_session_ms": direct_session_ms()}, indent=2))
