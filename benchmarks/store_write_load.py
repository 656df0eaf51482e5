"""Write and load speed of the session store; prints JSON.

A session of 15 000 rows x 9 raw channels (accel and gyro 100 Hz, mag 50 Hz with NaN cells), split as
the rig writes it: 20 holds of 500 rows and 19 moves of 263 rows, one transaction each, plus the same
rows as a single transaction. Times are the best and median of `--repeat` runs, each into a fresh
file; with synchronous=FULL they include one fsync per commit, so they depend on the disk and its load.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rig.store import SessionStore  # noqa: E402

N_HOLDS, HOLD_ROWS, MOVE_ROWS = 20, 500, 263


def segment(rng: np.random.Generator, t0: float, n: int) -> dict:
    mag = rng.normal(300, 5, (n, 3)).round()
    mag[1::2] = np.nan
    q = np.zeros((n, 4))
    q[:, 0] = 1.0
    return dict(t=t0 + np.arange(n) / 100.0, q_ref=q, table_deg=np.zeros((n, 2)),
                temp_c=np.full(n, 25.0), vsupply_v=np.full(n, 3.3),
                samples={"accel": rng.normal(0, 4000, (n, 3)).round(), "gyro": rng.normal(0, 20, (n, 3)).round(),
                         "mag": mag})


def session_segments() -> list[tuple[str, int, dict]]:
    rng = np.random.default_rng(0)
    out, t0 = [], 0.0
    for step in range(N_HOLDS):
        out.append(("hold", step, segment(rng, t0, HOLD_ROWS)))
        t0 += HOLD_ROWS / 100.0
        if step < N_HOLDS - 1:
            out.append(("move", step, segment(rng, t0, MOVE_ROWS)))
            t0 += MOVE_ROWS / 100.0
    return out


def joined(parts: list[dict]) -> dict:
    """All segments' rows as one segment (one transaction)."""
    out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k != "samples"}
    out["samples"] = {s: np.concatenate([p["samples"][s] for p in parts]) for s in parts[0]["samples"]}
    return out


def write(folder: Path, segments: list, synchronous: str) -> float:
    store = SessionStore.create(folder, {"benchmark": True})
    store._conn.execute(f"PRAGMA synchronous={synchronous}")
    start = time.perf_counter()
    for phase, step, arrays in segments:
        if phase == "hold":
            store.append_hold(step, commanded_deg=(0, 0), measured_deg=(0, 0), **arrays)
        else:
            store.append_move(step, **arrays)
    elapsed = time.perf_counter() - start
    store.close()
    return elapsed


def load(folder: Path) -> float:
    start = time.perf_counter()
    with SessionStore.open(folder) as store:
        store.to_session_data()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    segments = session_segments()
    rows = sum(a["t"].size for _, _, a in segments)
    single = [("hold", 0, joined([a for _, _, a in segments]))]
    results: dict = {"rows": rows, "raw_channels": 9, "transactions_session": len(segments), "repeat": args.repeat}
    with tempfile.TemporaryDirectory() as tmp:
        for label, segs in (("session", segments), ("single_transaction", single)):
            for sync in ("FULL", "NORMAL"):
                times = [write(Path(tmp) / f"{label}-{sync}-{i}", segs, sync) for i in range(args.repeat)]
                results[f"write_{label}_{sync.lower()}_s"] = {"best": round(min(times), 4),
                                                              "median": round(float(np.median(times)), 4)}
        loads = [load(Path(tmp) / f"session-FULL-{i}") for i in range(args.repeat)]
        results["open_and_load_session_s"] = {"best": round(min(loads), 4), "median": round(float(np.median(loads)), 4)}
        results["file_bytes"] = (Path(tmp) / "session-FULL-0" / "session.sqlite").stat().st_size
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
