"""`rig noise` on still logs of hours: wall time and peak memory of the command, warm-up search and motion blocks
included.

A still unit (accelerometer, gyroscope, magnetometer, 100 Hz, in counts) whose magnetometer warms up over its
first minute is written as a session at each length; `rig noise --json` runs on it in a child process whose
peak resident memory its parent reads (ru_maxrss). Prints JSON.
Usage: python benchmarks/bench_noise.py [--hours 0.25 1 6]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rig.io.recording import recording_session
from rig.io.session_writer import write_session

RATE_HZ = 100.0
WRAPPER = ("import resource, subprocess, sys; done = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL); "
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(done.returncode)")


def still_log(rows: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(rows) / RATE_HZ
    accel = np.round(np.array([20.0, -41.0, 2048.0]) + rng.normal(0.0, 3.0, (rows, 3)))
    gyro = np.round(np.array([-30.0, 12.0, 5.0]) + rng.normal(0.0, 2.0, (rows, 3)))
    mag = np.round(np.array([300.0, -120.0, 400.0]) + rng.normal(0.0, 2.0, (rows, 3))
                   + np.outer(np.exp(-t / 15.0), [200.0, -60.0, 30.0]))
    return recording_session(t, {"accel": accel, "gyro": gyro, "mag": mag},
                             units={"accel": "counts", "gyro": "counts", "mag": "counts"}, source="<bench>",
                             sample_rate_hz=RATE_HZ, field_uT=50.0)


def measured(argv: list[str]) -> dict:
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", WRAPPER, *argv], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed: {done.stderr[-500:]}")
    return {"wall_s": round(wall, 2), "peak_rss_mib": round(int(done.stderr.strip().splitlines()[-1]) / 1024, 1)}


def commit() -> str:
    done = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parent)
    return done.stdout.strip() or "unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=[0.25, 1.0, 6.0])
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    sizes = []
    with tempfile.TemporaryDirectory() as tmp:
        for hours in args.hours:
            rows = int(round(hours * 3600 * RATE_HZ))
            folder = write_session(still_log(rows), Path(tmp) / f"log_{rows}")
            run = measured([sys.executable, "-m", "rig.cli", "noise", str(folder), "--json", str(folder / "n.json")])
            report = json.loads((folder / "n.json").read_text())
            sizes.append({"hours": hours, "rows": rows, **run, "us_per_row": round(1e6 * run["wall_s"] / rows, 2),
                          "warm_ups_named": len(report["effects"]),
                          "mag_analysed_from_s": round(report["spans"]["mag"]["start_s"], 1)})
    print(json.dumps({"benchmark": "bench_noise", "date": datetime.datetime.now().isoformat(timespec="seconds"),
                      "commit": commit(), "machine": f"{platform.machine()} {platform.processor() or ''} "
                      f"{os.cpu_count()} cpus, python {platform.python_version()}".strip(),
                      "load": {"before": round(load_before, 2), "after": round(os.getloadavg()[0], 2)},
                      "rate_hz": RATE_HZ, "sizes": sizes}, indent=2))


if __name__ == "__main__":
    main()
