"""Eight simulated rigs writing to one PostgreSQL at once; then the same with the database killed mid-run.
Prints JSON.

Each rig is `rig calibrate --sim --time-scale 20 --config rig-K.toml` (its own unit serial) in its own process
with `rig push DIR --follow --rig sim-K` beside it (the live mirror); the server is Debian's PostgreSQL,
started here with fsync on. Phase "steady": nothing goes wrong. Phase "killed": once 30 % of the holds are in
the database its server is killed (SIGKILL to every server process) and started again 3 s later (crash
recovery); the rigs never stop. After each phase `rig push --all` runs, and every session folder is compared
with the database segment by segment (digest of the rows and arrays): holds lost (in the folder, not in the
database) and duplicated (stored more than once, or a session stored twice) are counted.

Usage: python benchmarks/bench_lab_rigs.py [--rigs 8] [--kill-after 0.3] [--down-s 3]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path

import psycopg

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rig.lab.local import LocalSession  # noqa: E402
from tests.lab.pgserver import PgServer  # noqa: E402

RIG = [sys.executable, "-m", "rig.cli"]


def stored_holds(url: str) -> int:
    try:
        with psycopg.connect(url, connect_timeout=2) as conn:
            if not conn.execute("SELECT to_regclass('segments') IS NOT NULL").fetchone()[0]:
                return 0
            return conn.execute("SELECT count(*) FROM segments WHERE phase = 'hold'").fetchone()[0]
    except psycopg.Error:
        return -1


def compare(root: Path, url: str) -> dict:
    lost = duplicated = holds = 0
    with psycopg.connect(url) as conn:
        for folder in sorted(p for p in root.iterdir() if (p / "session.sqlite").exists()):
            with LocalSession.open(folder) as local:
                key = local.key()
                segments = local.segments()
            rows = conn.execute("SELECT g.seq, g.digest FROM segments g JOIN sessions s ON s.id = g.session_id "
                                "WHERE s.key = %s", (key,)).fetchall()
            copies = conn.execute("SELECT count(*) FROM sessions WHERE name = %s", (folder.name,)).fetchone()[0]
            stored = {}
            for seq, digest in rows:
                stored.setdefault(seq, []).append(digest)
            holds += sum(s.phase == "hold" for s in segments)
            lost += sum(1 for s in segments if s.phase == "hold" and s.digest not in stored.get(s.seq, []))
            duplicated += sum(len(v) - 1 for v in stored.values()) + max(0, copies - 1)
    return {"holds_recorded": holds, "holds_lost": lost, "duplicated": duplicated}


def run_phase(root: Path, url: str, configs: list[Path], server: PgServer | None, kill_after: float,
              down_s: float) -> dict:
    root.mkdir(parents=True)
    t0 = time.monotonic()
    sessions, mirrors = [], []
    for k, config in enumerate(configs):
        out = root / f"rig-{k}"
        mirrors.append(subprocess.Popen([*RIG, "push", out, "--store", url, "--rig", f"sim-{k}", "--follow"],
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        sessions.append(subprocess.Popen([*RIG, "calibrate", "--sim", "--config", config, "--time-scale", "20",
                                          "--out", out, "--no-progress"], stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE, text=True))
    result: dict = {}
    if server is not None:
        target = kill_after * 20 * len(configs)
        while stored_holds(url) < target and any(p.poll() is None for p in sessions):
            time.sleep(0.1)
        result["killed_at_holds_stored"] = stored_holds(url)
        result["killed_at_s"] = time.monotonic() - t0
        server.kill()
        time.sleep(down_s)
        server.start()
        result["restarted_at_s"] = time.monotonic() - t0
    codes = [p.wait(timeout=600) for p in sessions]
    result["session_exit_codes"] = codes
    result["sessions_done_s"] = time.monotonic() - t0
    mirror_codes, lost_lines = [], 0
    for m in mirrors:
        try:
            _, err = m.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            m.terminate()
            _, err = m.communicate()
        mirror_codes.append(m.returncode)
        if os.environ.get("RIG_BENCH_LOG"):
            with open(os.environ["RIG_BENCH_LOG"], "a") as f:
                f.write(f"--- mirror {len(mirror_codes) - 1} exit {m.returncode}\n{err}\n")
        lost_lines += err.count("cannot be reached")
        if "Traceback" in err:
            result.setdefault("mirror_tracebacks", []).append(err[-400:])
    result["mirror_exit_codes"] = mirror_codes
    result["mirrors_that_saw_the_database_go"] = lost_lines
    result["after_mirrors"] = compare(root, url)
    push = subprocess.run([*RIG, "push", "--all", root, "--store", url], capture_output=True, text=True)
    result["push_all_exit"] = push.returncode
    result["push_all_last_line"] = push.stdout.strip().splitlines()[-1] if push.stdout.strip() else push.stderr
    result["after_push"] = compare(root, url)
    late = []
    for k in range(len(configs)):
        with LocalSession.open(root / f"rig-{k}") as local:
            late.append((local.metadata().get("acquisition") or {}).get("late_reads"))
    result["late_reads_per_rig"] = late
    result["wall_s"] = time.monotonic() - t0
    return result


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rigs", type=int, default=8)
    ap.add_argument("--kill-after", type=float, default=0.3)
    ap.add_argument("--down-s", type=float, default=3.0)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="rig-lab-rigs-"))
    os.environ["RIG_LOCK_DIR"] = str(work / "locks")
    base = resources.files("rig.configs").joinpath("sim.toml").read_text()
    configs = []
    for k in range(args.rigs):
        path = work / f"rig-{k}.toml"
        path.write_text(base.replace('serial = "SIM-0001"', f'serial = "LAB-UNIT-{k}"'))
        configs.append(path)
    server = PgServer(fsync=True)
    server.start()
    out = {"rigs": args.rigs, "time_scale": 20, "holds_per_session": 20, "cpu_count": os.cpu_count(),
           "loadavg_before": os.getloadavg()}
    try:
        out["steady"] = run_phase(work / "steady", server.createdb("steady"), configs, None, 0, 0)
        out["killed"] = run_phase(work / "killed", server.createdb("killed"), configs, server, args.kill_after,
                                  args.down_s)
        out["loadavg_after"] = os.getloadavg()
    finally:
        server.destroy()
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
