"""Batch discrepancy over an archive on Dask: 1 worker against 2 (target: 2 workers at least 1.8x faster).
Prints JSON.

The archive: N session folders (default 1000) written through the rig's SessionStore, each a simulated
session of the world model (`fixtures.world.session_sim`: 12 orientations, 1 s holds at 50 Hz, accel, gyro
and mag, about 2 200 rows, 12 holds and 11 moves), `--distinct` different recordings (unit and noise seeds)
reused under distinct identities (unit serial, rig, start time), pushed with `rig push`'s code into a
PostgreSQL server started here (Debian's package). Each task reads its session from the database on the
worker and runs `rig.discrepancy.analyze` (no replay); the client writes every result back to the database.
Times exclude starting the cluster (measured from the first task submitted to the last result stored).

Usage: python benchmarks/bench_lab_batch.py [--sessions 1000] [--distinct 25] [--archive DIR] [--keep]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rig.lab.batch import run_batch  # noqa: E402
from rig.lab.local import session_folders  # noqa: E402
from rig.lab.mirror import push_folder  # noqa: E402
from rig.lab.pg import connect  # noqa: E402
from rig.lab.pg_store import PgStore  # noqa: E402
from rig.lab.records import Filters  # noqa: E402
from tests.lab.archive import simulated, small_plan, write_session  # noqa: E402
from tests.lab.pgserver import PgServer  # noqa: E402


def make_archive(root: Path, n: int, distinct: int) -> float:
    t0 = time.perf_counter()
    plan = small_plan()
    bases = [simulated(100 + k, 1000 + k, plan) for k in range(distinct)]
    for i in range(n):
        day, minute = divmod(i, 600)
        write_session(root / f"arch-{i:05d}", bases[i % distinct], unit=f"ARCH-{i % distinct:03d}",
                      rig=f"rig-{i % 4}", start_utc=f"2026-01-{1 + day:02d}T{minute // 60:02d}:{minute % 60:02d}:00.000Z",
                      plan=plan, calibrate=False)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sessions", type=int, default=1000)
    ap.add_argument("--distinct", type=int, default=25)
    ap.add_argument("--archive", type=Path, default=None, help="reuse (or make) the archive here")
    ap.add_argument("--keep", action="store_true", help="keep the archive made in a temporary folder")
    args = ap.parse_args()
    root = args.archive or Path(tempfile.mkdtemp(prefix="rig-lab-archive-"))
    out = {"sessions": args.sessions, "distinct_recordings": args.distinct,
           "session": "simulated world, 12 orientations, 1 s holds at 50 Hz, accel+gyro+mag, 12 holds + 11 moves",
           "cpu_count": os.cpu_count(), "loadavg_before": os.getloadavg()}
    existing = len(session_folders(root)) if root.exists() else 0
    if existing < args.sessions:
        shutil.rmtree(root, ignore_errors=True)
        root.mkdir(parents=True)
        out["archive_write_s"] = make_archive(root, args.sessions, args.distinct)
    folders = session_folders(root)[:args.sessions]
    assert len(folders) == args.sessions, len(folders)
    server = PgServer()
    server.start()
    try:
        url = server.createdb("archive")
        t0 = time.perf_counter()
        conn = connect(url)
        for folder in folders:
            push_folder(folder, url, conn=conn)
        conn.close()
        out["push_s"] = time.perf_counter() - t0
        store = PgStore(url, write=True)
        keys = store.select_keys(Filters())
        assert len(keys) == len(folders), (len(keys), len(folders))
        for workers in (1, 2):
            summary = run_batch(store, url, "discrepancy", keys, workers=workers, echo=lambda _: None)
            assert summary["ok"] == len(keys), summary["failed"][:3]
            out[f"seconds_{workers}_worker{'s' if workers > 1 else ''}"] = summary["seconds"]
        store.close()
        out["speedup_2_vs_1"] = out["seconds_1_worker"] / out["seconds_2_workers"]
        out["target_speedup"] = 1.8
        out["loadavg_after"] = os.getloadavg()
    finally:
        server.destroy()
        if args.archive is None and not args.keep:
            shutil.rmtree(root, ignore_errors=True)
        elif args.archive is None:
            out["archive"] = str(root)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
