"""Benchmark of the turntable client (rig.turntable) against the fake turntable; prints JSON.

1. Modbus round trip of the 12-register feedback read (one FC03, +0x10..+0x1B) through the client's
   channel and through `axis_status` (read + decode), on every transport: Modbus TCP and RTU through a
   gateway (rtu+socket) on loopback, RTU on a serial line (a pty pair, unpaced, and paced at the URL's baud
   rate so the bytes take their real time). Beside each: what the line allows. For a serial line that is the
   time of the request's and the reply's characters, (8 + 5 + 2 n) bytes x (1 start + 8 data + parity + 1
   stop) bits / baud for an FC03 of n registers (Modbus over Serial Line V1.02, 2.5.1); on loopback it is a
   bare pymodbus client of the same framing on the same server. Target: every transport within 1.5x.
2. Moves per second through `TurntableLink.move_to` with a simulated clock (short moves), i.e. the
   client's own cost per move: Modbus transactions plus decoding, no waiting.

Run: `python benchmarks/bench_turntable.py [--reads 1000] [--moves 100]`.
"""

from __future__ import annotations

import argparse
import logging
import platform
import statistics
import time

import pymodbus
from pymodbus import FramerType
from pymodbus.client import ModbusTcpClient

from fixtures.turntable import FakeTurntable, TurntableServer
from rig.clock import SimClock
from rig.turntable import TurntableLink, load_profile

import stamp  # benchmarks/stamp.py


def percentile(sorted_ms: list[float], q: float) -> float:
    return sorted_ms[min(len(sorted_ms) - 1, int(round(q * (len(sorted_ms) - 1))))]


def summary(times_s: list[float]) -> dict:
    ms = sorted(t * 1e3 for t in times_s)
    return {"n": len(ms), "median_ms": round(statistics.median(ms), 4), "p99_ms": round(percentile(ms, 0.99), 4),
            "max_ms": round(ms[-1], 4)}


def line_time_ms(registers: int, baud: int, parity: str = "N") -> float:
    """Characters of an RTU FC03 request (8 bytes) and its reply (5 + 2n bytes) at `baud`, in ms."""
    bits = 1 + 8 + (parity != "N") + 1
    return 1e3 * (8 + 5 + 2 * registers) * bits / baud


def bare_pymodbus_ms(srv, address: int, count: int, n: int) -> float:
    """Median FC03 round trip of a plain pymodbus client of the transport's framing: the loopback floor."""
    framer = FramerType.SOCKET if srv.transport == "tcp" else FramerType.RTU
    client = ModbusTcpClient(srv.host, port=srv.port, framer=framer, timeout=1.0)
    client.connect()
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        client.read_holding_registers(address, count=count, device_id=1)
        times.append(time.perf_counter() - t0)
    client.close()
    return statistics.median(times) * 1e3


def round_trips(transport: str, n: int, paced: bool = False) -> dict:
    profile = load_profile()
    start, count = profile.feedback_block()
    address = profile.axis_bases[0] + start
    clock = SimClock()
    with TurntableServer(FakeTurntable(clock=clock), transport=transport, paced=paced) as srv, \
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
        if transport == "rtu-pty":
            line = {"line_ms": round(line_time_ms(count, srv.baudrate, srv.parity), 4),
                    "line": f"{srv.baudrate} baud, paced" if paced else "pty, no baud rate (bytes cross at once)"}
        else:
            line = {"line_ms": round(bare_pymodbus_ms(srv, address, count, max(n, 200)), 4),
                    "line": "bare pymodbus client, same framing, same server, loopback"}
    fc03 = summary(raw)
    return {"transport": transport + (" paced" if paced else ""), "url_scheme": srv.url.split("://")[0],
            "registers": count, "fc03_read": fc03, "axis_status_read_and_decode": summary(decoded),
            **line, "ratio_to_line": round(fc03["median_ms"] / line["line_ms"], 3), "failures": failures}


def moves_per_second(transport: str, n: int, paced: bool = False) -> dict:
    clock = SimClock()
    with TurntableServer(FakeTurntable(clock=clock), transport=transport, paced=paced) as srv, \
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
    return {"transport": transport + (" paced" if paced else ""), "moves": n, "move_deg": 1.0, "speed_dps": 30.0, "accel_dps2": 60.0,
            "settle_s": 0.2, "poll_interval_s": 0.05, "wall_s": round(wall, 3),
            "moves_per_s": round(n / wall, 1), "virtual_s_per_move": round(virtual / n, 3),
            "modbus_requests_per_move": round(requests / n, 1),
            "wall_ms_per_request": round(1e3 * wall / requests, 4)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reads", type=int, default=1000)
    parser.add_argument("--moves", type=int, default=100)
    stamp.add_save_option(parser)
    args = parser.parse_args()
    run = stamp.start("bench_turntable")
    logging.disable(logging.WARNING)
    out = {
        "benchmark": "bench_turntable",
        "server": "fixtures.turntable.FakeTurntable via TurntableServer (pymodbus server in a thread, same process)",
        "python": platform.python_version(), "pymodbus": pymodbus.__version__,
        "round_trip": [round_trips("tcp", args.reads), round_trips("rtu-tcp", args.reads),
                       round_trips("rtu-pty", args.reads), round_trips("rtu-pty", args.reads // 2, paced=True)],
        "moves": [moves_per_second("tcp", args.moves), moves_per_second("rtu-tcp", args.moves),
                  moves_per_second("rtu-pty", args.moves), moves_per_second("rtu-pty", args.moves // 4, paced=True)],
        "target": "median FC03 round trip on loopback TCP < 1 ms; every transport within 1.5x of its line",
    }
    out["target_met"] = (out["round_trip"][0]["fc03_read"]["median_ms"] < 1.0
                         and all(r["ratio_to_line"] <= 1.5 for r in out["round_trip"] if "paced" in r["transport"]
                                 or not r["transport"].startswith("rtu-pty")))
    figures = {}
    for r in out["round_trip"]:
        name = r["transport"].replace(" ", "_").replace("-", "_")
        figures[f"{name}_fc03_median_ms"] = r["fc03_read"]["median_ms"]
        if r["transport"] != "rtu-pty":           # an unpaced pty has no line time to compare with
            figures[f"{name}_ratio_to_line"] = r["ratio_to_line"]
    for m in out["moves"]:
        figures[f"{m['transport'].replace(' ', '_').replace('-', '_')}_moves_per_s"] = m["moves_per_s"]
    figures["target_met"] = out["target_met"]
    stamp.report(run, figures, {k: v for k, v in out.items() if k != "benchmark"}, save=args.save)


if __name__ == "__main__":
    main()
