"""Benchmark: `rig calibrate --sim` end to end (20 orientations x 5 s holds, accel/gyro 100 Hz, mag 50 Hz,
the turntable over Modbus TCP on loopback), two boards x --seeds seeds, each a whole process (after one warm-up run).
Prints JSON: wall time, rig time, speed-up, samples, late reads, and the H/B errors against the simulator's truth.
Usage: python benchmarks/bench_sim_session.py [--seeds N]"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import stamp  # noqa: E402  (benchmarks/stamp.py)

from rig.store import SessionStore  # noqa: E402


def one(seed: int, board: str) -> dict:
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "s"
        cfg = Path(d) / "rig.toml"
        text = resources.files("rig.configs").joinpath("sim.toml").read_text().replace('board = "bsn"', f'board = "{board}"')
        cfg.write_text(text)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "rig.cli", "calibrate", "--sim", "--config", str(cfg), "--seed",
                        str(seed), "--no-progress", "--out", str(out)], check=True, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        store = SessionStore.open(out)
        meta = store.metadata
        session = store.to_session_data()
        cal = json.loads((out / "calibration.json").read_text())
        truth = json.loads((out / "truth.json").read_text())
        errs = {}
        for name in cal["sensors"]:
            H, Ht = np.array(cal["sensors"][name]["H"]), np.array(truth["sensors"][name]["H"])
            B, Bt = np.array(cal["sensors"][name]["B"]), np.array(truth["sensors"][name]["B"])
            errs[name] = {"H_rel_frobenius_pct": float(np.linalg.norm(H - Ht) / np.linalg.norm(Ht) * 100),
                          "B_rel_pct": float(np.linalg.norm(B - Bt) / np.linalg.norm(Bt) * 100)}
        counts = {n: int((~np.isnan(v).any(axis=1)).sum()) for n, v in session.raw.items()}
        rig_time = float(session.t[-1] - session.t[0])
        return {"board": board, "seed": seed, "wall_s": round(wall, 3), "rig_time_s": round(rig_time, 2),
                "speedup": round(rig_time / wall, 1), "rows": int(session.t.size), "samples": counts,
                "expected_rows": int(round(rig_time * 100)) + 1, "acquisition": meta.get("acquisition"),
                "errors_vs_truth": errs}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    stamp.add_save_option(parser)
    args = parser.parse_args()
    run = stamp.start("bench_sim_session")
    one(0, "bsn")                                  # warm-up, not counted: byte-code caches written
    runs = [one(seed, board) for board in ("bsn", "wearable") for seed in range(args.seeds)]
    walls = [r["wall_s"] for r in runs]
    figures = {"median_wall_s": round(float(np.median(walls)), 3), "max_wall_s": max(walls)}
    for board in ("bsn", "wearable"):
        mine = [r for r in runs if r["board"] == board]
        figures[f"{board}_median_wall_s"] = round(float(np.median([r["wall_s"] for r in mine])), 3)
        figures[f"{board}_median_speedup_x"] = round(float(np.median([r["speedup"] for r in mine])), 1)
    stamp.report(run, figures, {"what": f"rig calibrate --sim, {args.seeds} seeds x 2 boards",
                                "runs": runs}, save=args.save)


if __name__ == "__main__":
    main()
