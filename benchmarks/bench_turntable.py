"""Benchmark of the turntable client (rig.turntable) against the fake turntable; prints JSON.

1. Modbus round trip of the 12-register feedback read (one FC03, +0x10..+0x1B) through the client's
   channel and through `axis_status` (read + decode), on loopback Modbus TCP and RTU-over-TCP.
2. Moves per second through `TurntableLink.move_to` with a simulated clock (short moves), i.e. the
   client's own cost per move: Modbus transactions plus decoding, no waiting.

Run: `python benchmarks/bench_turntable.py [--reads 1000] [--moves 100]`.
"""

from __future__ import annotations

import argparse
import json
import logging
import platform
import statistics
import time

import pymodbus

from fixtures.turntable import FakeTurntable, TurntableServer
from rig.clock import SimClock
from rig.turntable import TurntableLink, load_profile


def percentile(sorted_ms: list[float], q: float) -> float:
    return sorted_ms[min(len(sorted_ms) - 1, int(round(q * (len(sorted_ms) - 1))))]


def summary(times_s: list[float]) -> dict:
    ms = sorted(t * 1e3 for t in times_s)
    return {"n": len(ms), "median_ms": round(statistics.median(ms), 4), "p99_ms": round(percentile(ms, 0.99), 4),
            "max_ms": round(ms[-1], 4)}


def round_trips(transport: str, n: int) -> dict:
    profile = load_profile()
    start, count = profile.feedback_block()
    address = profile.axis_bases[0] + start
    clock = SimClock()
    with TurntableServer(FakeTurntable(clock=clock), transport=transport) as srv, \
            TurntableLink(srv.url, clock=clock, timeout=1.0) as link:
        for _ in range(20):
            link.channel.read(address, count, "warm-up")
        raw, decoded = [], []
        for _ in range(n):
            t0 = time.perf_counter()
            link.channel.read(address, count, "axis 0 feedback")
            raw.append(time.perf_counter() - t0)
        for _ in range(n):
            t0 = time.perf_counter()
            link.axis_status(0)
            decoded.append(time.perf_counter() - t0)
        failures = link.channel.failures
    return {"transport": transport, "url_scheme": srv.url.split("://")[0], "registers": count,
            "fc03_read": summary(raw), "axis_status_read_and_decode": summary(decoded), "failures": failures}


def moves_per_second(transport: str, n: int) -> dict:
    clock = SimClock()
    with TurntableServer(FakeTurntable(clock=clock), transport=transport) as srv, \
            TurntableLink(srv.url, clock=clock, timeout=1.0) as link:
        link.enable()
        requests0, virtual0 = link.channel.requests, clock.now()
        t0 = time.perf_counter()
        for i in range(n):
            angle = 1.0 if i % 2 == 0 else 0.0
            link.move_to(angle, -angle, speed_dps=30.0, accel_dps2=60.0, settle_s=0.2)
        wall = time.perf_counter() - t0
        requests = link.channel.requests - requests0
        virtual = clock.now() - virtual0
    return {"transport": transport, "moves": n, "move_deg": 1.0, "speed_dps": 30.0, "accel_dps2": 60.0,
            "settle_s": 0.2, "poll_interval_s": 0.05, "wall_s": round(wall, 3),
            "moves_per_s": round(n / wall, 1), "virtual_s_per_move": round(virtual / n, 3),
            "modbus_requests_per_move": round(requests / n, 1),
            "wall_ms_per_request": round(1e3 * wall / requests, 4)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reads", type=int, default=1000)
    parser.add_argument("--moves", type=int, default=100)
    args = parser.parse_args()
    logging.disable(logging.WARNING)
    out = {
        "benchmark": "bench_turntable",
        "server": "fixtures.turntable.FakeTurntable via TurntableServer (pymodbus server in a thread, same process)",
        "python": platform.python_version(), "pymodbus": pymodbus.__version__,
        "round_trip": [round_trips("tcp", args.reads), round_trips("rtu-tcp", max(50, args.reads // 10))],
        "moves": [moves_per_second("tcp", args.moves), moves_per_second("rtu-tcp", max(5, args.moves // 20))],
        "target": "median FC03 round trip on loopback TCP < 1 ms",
    }
    out["target_met"] = out["round_trip"][0]["fc03_read"]["median_ms"] < 1.0
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
