"""Simulated rigs on one PostgreSQL: how the rigs treat the server when it refuses them or goes away, and whether
every hold reaches it. Prints JSON.

Each rig is `rig calibrate --sim --time-scale 20 --config rig-K.toml` (its own unit serial) in its own process
with `rig push DIR --follow --rig sim-K` beside it (the live mirror). The server is Debian's PostgreSQL, started
here with fsync on; each rig reaches it through its own counting relay (`tests/lab/proxy.py`), so every
connection attempt of every rig is counted with its time, even while the server is down.

Phases (`--phases`, comma-separated):
- `wrong_password`: one rig whose password file holds a wrong password, once as `rig push --follow` and once
  as `rig calibrate --store` (the mirror inside the rig): connection attempts, the server's failed logins (its
  log), the lines the rig printed about the store, the exit codes, and the session's time against the same
  session without a store.
- `store_away`: `rig calibrate --sim --store URL` with nothing listening behind the relay: the session's time
  and the attempts it made.
- `down`: `--rigs` rigs; once 30 % of the holds are in the database the server is killed (SIGKILL to every
  server process) and started again `--down-s` later (crash recovery); the rigs never stop. Per rig: the most
  attempts within any 1 s, the smallest gap between two attempts, the attempts while the server was down.
  Then every session folder is compared with the database segment by segment (digest of the rows and
  arrays): holds lost (in the folder, not in the database) and duplicated, after the mirrors alone, then
  after `rig push --all`.
- `steady`: the same rigs with nothing going wrong.

Usage: python benchmarks/bench_lab_rigs.py [--rigs 8] [--down-s 60] [--phases wrong_password,store_away,down]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from importlib import resources
from pathlib import Path

import psycopg

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rig.lab.local import LocalSession  # noqa: E402
from tests.lab.pgserver import PgServer, free_port  # noqa: E402
from tests.lab.proxy import CountingProxy  # noqa: E402

RIG = [sys.executable, "-m", "rig.cli"]
HOLDS = 20                        # orientations of sim.toml


def header() -> dict:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip()
    return {"benchmark": "bench_lab_rigs", "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "commit": commit, "machine": {"node": platform.node(), "cpus": os.cpu_count(),
                                          "python": platform.python_version(), "system": platform.platform()},
            "load": os.getloadavg()}


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
            stored: dict[int, list[str]] = {}
            for seq, digest in rows:
                stored.setdefault(seq, []).append(digest)
            holds += sum(s.phase == "hold" for s in segments)
            lost += sum(1 for s in segments if s.phase == "hold" and s.digest not in stored.get(s.seq, []))
            duplicated += sum(len(v) - 1 for v in stored.values()) + max(0, copies - 1)
    return {"holds_recorded": holds, "holds_lost": lost, "duplicated": duplicated}


def attempt_figures(proxy: CountingProxy, start: float | None = None, end: float | None = None) -> dict:
    times = proxy.attempts if start is None else proxy.between(start, end)
    gaps = [b - a for a, b in zip(times, times[1:])]
    most = max((sum(1 for u in times if t <= u < t + 1.0) for t in times), default=0)
    return {"attempts": len(times), "most_in_any_1s": most, "smallest_gap_s": round(min(gaps), 3) if gaps else None}


def session(config: Path, out: Path, store: str | None = None) -> tuple[int, float, str]:
    args = [*RIG, "calibrate", "--sim", "--config", config, "--time-scale", "20", "--out", out, "--no-progress"]
    t0 = time.monotonic()
    done = subprocess.run(args + (["--store", store] if store else []), capture_output=True, text=True, timeout=600)
    return done.returncode, time.monotonic() - t0, done.stderr


def phase_wrong_password(work: Path, server: PgServer, config: Path) -> dict:
    server.sql("CREATE ROLE rig_pw LOGIN PASSWORD 'the-right-one'")
    db = server.createdb("wrong_password").rsplit("/", 1)[1]
    passfile = work / "pgpass"
    passfile.write_text("127.0.0.1:*:*:rig_pw:not-the-right-one\n")
    passfile.chmod(0o600)
    os.environ["PGPASSFILE"] = str(passfile)
    log = server.root / "server.log"
    failed_before = log.read_text(errors="replace").count("password authentication failed")
    out: dict = {}
    proxy = CountingProxy(server.port)
    try:
        url = proxy.url(db, "rig_pw")
        code, wall, err = session(config, work / "pw-alone")
        out["session_without_store"] = {"exit": code, "wall_s": round(wall, 2)}
        t0 = time.monotonic()
        follow = subprocess.run([*RIG, "push", work / "pw-alone", "--store", url, "--follow"], capture_output=True,
                                text=True, timeout=600)
        lines = [ln for ln in follow.stderr.splitlines() if not ln.startswith("following ")]
        out["push_follow"] = {"exit": follow.returncode, "wall_s": round(time.monotonic() - t0, 2),
                              **attempt_figures(proxy), "lines": len(lines), "line": lines[0] if lines else None}
        proxy.attempts.clear()
        code, wall, err = session(config, work / "pw-live", url)
        lines = [ln for ln in err.splitlines() if "127.0.0.1" in ln]
        out["calibrate_store"] = {"exit": code, "wall_s": round(wall, 2), **attempt_figures(proxy),
                                  "lines": len(lines)}
    finally:
        proxy.close()
        os.environ.pop("PGPASSFILE", None)
    time.sleep(0.5)
    out["server_failed_logins"] = log.read_text(errors="replace").count("password authentication failed") - failed_before
    return out


def phase_store_away(work: Path, config: Path) -> dict:
    proxy = CountingProxy(free_port())                 # nothing listens behind it
    try:
        code, wall, err = session(config, work / "away", proxy.url("lab", "rig"))
        return {"exit": code, "wall_s": round(wall, 2), **attempt_figures(proxy),
                "last_line": err.strip().splitlines()[-1] if err.strip() else ""}
    finally:
        proxy.close()


def run_rigs(root: Path, server: PgServer, db: str, configs: list[Path], kill_after: float | None,
             down_s: float) -> dict:
    root.mkdir(parents=True)
    url = server.url(db)
    proxies = [CountingProxy(server.port) for _ in configs]
    t0 = time.monotonic()
    sessions, mirrors = [], []
    for k, (config, proxy) in enumerate(zip(configs, proxies)):
        out = root / f"rig-{k}"
        mirrors.append(subprocess.Popen([*RIG, "push", out, "--store", proxy.url(db, "rig"), "--rig", f"sim-{k}",
                                         "--follow", "--wait-s", str(down_s + 120)], stdout=subprocess.PIPE,
                                        stderr=subprocess.PIPE, text=True))
        sessions.append(subprocess.Popen([*RIG, "calibrate", "--sim", "--config", config, "--time-scale", "20",
                                          "--out", out, "--no-progress"], stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE, text=True))
    result: dict = {}
    down_at = back_at = None
    try:
        if kill_after is not None:
            target = kill_after * HOLDS * len(configs)
            while stored_holds(url) < target and any(p.poll() is None for p in sessions):
                time.sleep(0.1)
            result["killed_at_holds_stored"] = stored_holds(url)
            server.kill()
            down_at = time.monotonic()
            result["killed_at_s"] = round(down_at - t0, 1)
            time.sleep(down_s)
            server.start()
            back_at = time.monotonic()
            result["restarted_at_s"] = round(back_at - t0, 1)
        result["session_exit_codes"] = [p.wait(timeout=900) for p in sessions]
        result["sessions_done_s"] = round(time.monotonic() - t0, 1)
        mirror_codes, saw_it_go = [], 0
        for m in mirrors:
            try:
                _, err = m.communicate(timeout=down_s + 300)
            except subprocess.TimeoutExpired:
                m.terminate()
                _, err = m.communicate()
            mirror_codes.append(m.returncode)
            saw_it_go += "cannot be reached" in err
            if "Traceback" in err:
                result.setdefault("mirror_tracebacks", []).append(err[-400:])
        result["mirror_exit_codes"] = mirror_codes
        result["mirrors_done_s"] = round(time.monotonic() - t0, 1)
        result["mirrors_that_saw_the_database_go"] = saw_it_go
        per_rig = [attempt_figures(p) for p in proxies]
        result["attempts_per_rig"] = [f["attempts"] for f in per_rig]
        result["most_attempts_in_any_1s_per_rig"] = max(f["most_in_any_1s"] for f in per_rig)
        result["smallest_gap_s"] = min((f["smallest_gap_s"] for f in per_rig if f["smallest_gap_s"] is not None),
                                       default=None)
        if down_at is not None:
            result["attempts_while_down_per_rig"] = [len(p.between(down_at, back_at)) for p in proxies]
            after = [[t for t in p.attempts if t > back_at] for p in proxies]
            result["first_attempt_after_return_s"] = [round(a[0] - back_at, 1) if a else None for a in after]
    finally:
        for p in proxies:
            p.close()
    result["after_mirrors"] = compare(root, url)
    push = subprocess.run([*RIG, "push", "--all", root, "--store", url], capture_output=True, text=True)
    result["push_all_exit"] = push.returncode
    result["push_all_last_line"] = push.stdout.strip().splitlines()[-1] if push.stdout.strip() else push.stderr
    result["after_push"] = compare(root, url)
    result["wall_s"] = round(time.monotonic() - t0, 1)
    return result


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rigs", type=int, default=8)
    ap.add_argument("--kill-after", type=float, default=0.3)
    ap.add_argument("--down-s", type=float, default=60.0)
    ap.add_argument("--phases", default="wrong_password,store_away,down")
    args = ap.parse_args()
    phases = [p.strip() for p in args.phases.split(",") if p.strip()]
    work = Path(tempfile.mkdtemp(prefix="rig-lab-rigs-"))
    os.environ["RIG_LOCK_DIR"] = str(work / "locks")
    base = resources.files("rig.configs").joinpath("sim.toml").read_text()
    configs = []
    for k in range(args.rigs):
        path = work / f"rig-{k}.toml"
        path.write_text(base.replace("[unit]\n", f"[unit]\nserial = \"LAB-UNIT-{k}\"\n", 1))
        configs.append(path)
    out = header()
    out.update({"rigs": args.rigs, "time_scale": 20, "holds_per_session": HOLDS, "down_s": args.down_s})
    server = PgServer(fsync=True)
    server.start()
    try:
        if "wrong_password" in phases:
            out["wrong_password"] = phase_wrong_password(work, server, configs[0])
        if "store_away" in phases:
            out["store_away"] = phase_store_away(work, configs[0])
        if "steady" in phases:
            out["steady"] = run_rigs(work / "steady", server, "steady", configs, None, 0.0)
        if "down" in phases:
            server.createdb("down")
            out["down"] = run_rigs(work / "down", server, "down", configs, args.kill_after, args.down_s)
        out["load_after"] = os.getloadavg()
    finally:
        server.destroy()
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
