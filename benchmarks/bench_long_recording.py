"""Long recordings are ordinary: a static log of hours at 100 Hz imported and read, time and memory per size.

A logger's CSV (accelerometer in g, gyroscope in counts, temperature; what an Allan-variance run produces) is
written at several lengths up to 6 hours (2.16 million rows), then, each in a fresh process so the peak
resident memory is that of the step alone: `rig import csv` (read, check, write the session),
`rig.io.session_csv.read_session` of the result (what every command does first) and `rig noise` (the Allan
deviation and noise terms of every axis, what the log is recorded for). Targets: time linear in the rows, memory
under 1 GB. With `--twin`, also `rig discrepancy` (the log against its twin, docs/guides/discrepancy.md): its workers are forked, so its memory is the proportional set size of the command and its workers
summed, sampled every 0.5 s (Linux /proc), not one process's peak. Prints JSON.
Usage: python benchmarks/bench_long_recording.py [--hours 0.25 1 6] [--twin]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

RATE_HZ = 100.0
READ = "import sys; from rig.io.session_csv import read_session; s = read_session(sys.argv[1]); print(len(s.t))"


def write_log(path: Path, rows: int, seed: int = 0) -> None:
    """A still unit: accelerometer noise of 0.3 mg, gyroscope of 2 counts, a slow temperature drift."""
    rng = np.random.default_rng(seed)
    block = 200_000
    with open(path, "w") as f:
        f.write("time_s,ax,ay,az,gx,gy,gz,temp\n")
        for lo in range(0, rows, block):
            k = np.arange(lo, min(rows, lo + block))
            a = np.array([0.002, -0.001, 1.0]) + rng.normal(0, 3e-4, (len(k), 3))
            g = np.round(rng.normal([3, -2, 1], 2.0, (len(k), 3))).astype(int)
            temp = 25.0 + 2.0 * k / max(rows, 1)
            lines = [f"{kk / RATE_HZ:.2f},{x:.6f},{y:.6f},{z:.6f},{p},{q},{r},{tc:.3f}\n"
                     for kk, (x, y, z), (p, q, r), tc in zip(k.tolist(), a.tolist(), g.tolist(), temp.tolist())]
            f.writelines(lines)


WRAPPER = ("import resource, subprocess, sys; done = subprocess.run(sys.argv[1:]); "
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(done.returncode)")


def measured(argv: list[str]) -> dict:
    """Wall time and peak resident memory of one child process (its parent reports the child's ru_maxrss)."""
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", WRAPPER, *argv], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed: {done.stderr[-500:]}")
    peak_kib = int(done.stderr.strip().splitlines()[-1])
    return {"wall_s": round(wall, 3), "peak_rss_mib": round(peak_kib / 1024, 1)}


def tree_pss_mib(pid: int) -> float:
    """The proportional set size (MiB) of a process and all its descendants now (shared pages split among them)."""
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        try:
            total += next(int(line.split()[1]) for line in Path(f"/proc/{p}/smaps_rollup").read_text().splitlines()
                          if line.startswith("Pss:"))
            todo += [int(c) for t in Path(f"/proc/{p}/task").iterdir()
                     for c in (t / "children").read_text().split()]
        except (OSError, StopIteration, ValueError):
            continue
    return total / 1024


def measured_tree(argv: list[str]) -> dict:
    """Wall time and the peak summed PSS of a command whose work runs in forked workers."""
    t0, peak = time.perf_counter(), 0.0
    with subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True) as proc:
        while proc.poll() is None:
            peak = max(peak, tree_pss_mib(proc.pid))
            time.sleep(0.5)
        err = proc.stderr.read()
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(argv)} failed: {err[-500:]}")
    return {"wall_s": round(time.perf_counter() - t0, 3), "peak_pss_mib": round(peak, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=[0.25, 1.0, 6.0])
    parser.add_argument("--twin", action="store_true", help="also the log against its twin (rig discrepancy)")
    args = parser.parse_args()
    sizes = []
    with tempfile.TemporaryDirectory() as tmp:
        for hours in args.hours:
            rows = int(round(hours * 3600 * RATE_HZ))
            log = Path(tmp) / f"log_{rows}.csv"
            write_log(log, rows)
            out = Path(tmp) / f"session_{rows}"
            imported = measured([sys.executable, "-m", "rig.cli", "import", "csv", str(log), "--time", "time_s",
                                 "--accel", "ax,ay,az", "--gyro", "gx,gy,gz", "--temp", "temp",
                                 "--units", "accel=g", "--out", str(out)])
            read = measured([sys.executable, "-c", READ, str(out)])
            analysed = measured([sys.executable, "-m", "rig.cli", "noise", str(out), "--json", str(out / "noise.json")])
            sizes.append({"hours": hours, "rows": rows, "csv_mib": round(log.stat().st_size / 2 ** 20, 1),
                          "import": imported, "read_session": read, "noise": analysed,
                          "import_us_per_row": round(1e6 * imported["wall_s"] / rows, 2),
                          "read_us_per_row": round(1e6 * read["wall_s"] / rows, 2),
                          "noise_us_per_row": round(1e6 * analysed["wall_s"] / rows, 2)})
            if args.twin:
                twin = measured_tree([sys.executable, "-m", "rig.cli", "discrepancy", str(out), "--json",
                                      str(out / "d.json")])
                summary = json.loads((out / "d.json").read_text())["twin"]["summary"]
                sizes[-1]["twin"] = {**twin, "twin_us_per_row": round(1e6 * twin["wall_s"] / rows, 2),
                                     **{k: summary[k] for k in ("statistics", "inside_before", "inside_after")}}
            log.unlink()
    biggest = max(sizes, key=lambda s: s["rows"])
    print(json.dumps({
        "benchmark": "long_recording", "rate_hz": RATE_HZ, "sizes": sizes, "load_average": os.getloadavg()[0],
        "targets": {"peak_rss_mib_max": 1024, "linear": "us per row about constant across sizes"},
        "target_met": all(s[step]["peak_rss_mib"] < 1024 for s in sizes for step in ("import", "read_session", "noise"))
        and all(s["twin"]["peak_pss_mib"] < 1024 for s in sizes if "twin" in s) and biggest["rows"] >= 2_000_000,
    }, indent=2))


if __name__ == "__main__":
    main()
