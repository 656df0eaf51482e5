"""The twin of each real recording: `rig discrepancy DIR` as a user runs it, timed as a
process (with --heldout, which adds every leave-one-out refit twice), and what it found: statistics inside the
replicas' 1-99 % band before and after the extension, the causes named, the model tests, what stays unexplained.
Beside the wall time, the CPU seconds of the command and its workers and the machine's load before and after it:
on a machine shared with others the CPU seconds are the figure their work does not change (on an idle 2-core
machine the wall time is about half of them plus the serial start). Every recording in tests/data that the
importers read is used, and the MPU-6050 still log of tests/data (docs/guides/noise.md); a recording that is not
there is reported as missing, not skipped silently. Prints JSON.
Usage: python benchmarks/bench_twin.py [--replicas N] [--data tests/data] [--only NAME]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RIG = [sys.executable, "-m", "rig.cli"]
STILL_LOG = ROOT / "tests" / "data" / "mpu6050-tomisuarez2" / "example_data_tinit_calc.csv"


def imports(data: Path) -> dict[str, list[str]]:
    return {
        "imu_tk-xsens": ["imu_tk", "--accel", str(data / "imu_tk-xsens/xsens_acc.mat"),
                         "--gyro", str(data / "imu_tk-xsens/xsens_gyro.mat")],
        "imucal-ferraris-si": ["ferraris", "--csv", str(data / "imucal-ferraris/example_ferraris_session.csv"),
                               "--sections", str(data / "imucal-ferraris/example_ferraris_session_list.json"),
                               "--rate-hz", "102.4", "--units", "accel=m/s^2,gyro=deg/s"],
        "imucal-ferraris-raw": ["ferraris", "--annotated", str(data / "imucal-ferraris/annotated_session.csv"),
                                "--rate-hz", "204.8"],
        "tomisuarez2-still": ["csv", str(STILL_LOG), "--header-line", "5", "--rate-hz", "100", "--accel", "ax,ay,az",
                              "--gyro", "gx,gy,gz"],
    }


def _children_cpu() -> float:
    """User + system seconds of the finished child processes (the command and the workers it waited for)."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicas", type=int, default=None, help="default: the command's own (99, fewer for long ones)")
    ap.add_argument("--only", action="append", default=None, help="this recording only (repeatable)")
    ap.add_argument("--data", type=Path, default=ROOT / "tests" / "data")
    args = ap.parse_args()
    unknown = set(args.only or ()) - set(imports(args.data))
    if unknown:
        ap.error(f"--only: no recording named {', '.join(sorted(unknown))}; known: {', '.join(imports(Path('.')))}")
    out = {"replicas": args.replicas, "cpus": os.cpu_count(), "load_1min": os.getloadavg()[0], "recordings": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for name, argv in imports(args.data).items():
            if args.only and name not in args.only:
                continue
            folder = Path(tmp) / name
            done = subprocess.run([*RIG, "import", *argv, "--out", str(folder)], capture_output=True, text=True,
                                  check=False)
            if done.returncode != 0:
                out["recordings"][name] = {"missing": done.stderr.strip().splitlines()[-1:]}
                continue
            load0, cpu0 = os.getloadavg()[0], _children_cpu()
            t0 = time.perf_counter()
            run = subprocess.run([*RIG, "discrepancy", str(folder), "--json", str(folder / "d.json"),
                                  *(["--replicas", str(args.replicas)] if args.replicas else []), "--heldout"],
                                 capture_output=True, text=True, check=False)
            seconds = time.perf_counter() - t0
            cpu, load1 = _children_cpu() - cpu0, os.getloadavg()[0]
            if run.returncode not in (0, 1):
                out["recordings"][name] = {"exit": run.returncode, "stderr": run.stderr[-500:]}
                continue
            twin = json.loads((folder / "d.json").read_text())["twin"]
            s = twin["summary"]
            out["recordings"][name] = {
                "replicas": twin["replicas"], "band_chance": round(twin["band_chance"], 4),
                "seconds": round(seconds, 1), "cpu_seconds": round(cpu, 1), "load_1min_before": round(load0, 2),
                "load_1min_after": round(load1, 2), "statistics": s["statistics"], "inside_before": s["inside_before"],
                "inside_after": s["inside_after"], "inside_after_pct": round(100 * s["inside_after"] / s["statistics"], 1),
                "causes": [{"effect": c["effect"], "sensor": c["sensor"], "magnitude": c["magnitude"], "unit": c["unit"],
                            "brings_back": len(c["brings_back"])} for c in twin["causes"]],
                "model_tests": [{k: t[k] for k in ("effect", "sensor", "magnitude", "uncertainty", "unit", "p_holm",
                                                   "significant")} for t in twin["model_tests"]],
                "unexplained": len(twin["unexplained"]),
                "heldout_change": twin.get("heldout_change")}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
