"""The live mirror when the database misbehaves: killed and restarted mid-session, refusing connections,
read-only. The session always finishes locally; what reaches the store is exactly what the folder holds,
after the mirror or after `rig push`."""

from __future__ import annotations

import subprocess
import threading
import time

import psycopg

from rig.lab.mirror import SessionMirror, live_mirror

from .conftest import RIG, make_archive, rig
from .pgserver import PgServer, free_port
from .test_push import local_counts, stored_counts


def _stored_holds(url: str) -> int:
    try:
        with psycopg.connect(url, connect_timeout=2) as conn:
            exists = conn.execute("SELECT to_regclass('segments') IS NOT NULL").fetchone()[0]
            return conn.execute("SELECT count(*) FROM segments WHERE phase = 'hold'").fetchone()[0] if exists else 0
    except psycopg.Error:
        return -1


def test_the_database_killed_mid_session_and_restarted_loses_and_duplicates_nothing(tmp_path):
    server = PgServer()
    server.start()
    try:
        url = server.createdb("lab")
        out = tmp_path / "session"
        log: list[str] = []
        with live_mirror(out, url, rig="r-kill", echo=log.append) as mirror:
            proc = subprocess.Popen([*RIG, "calibrate", "--sim", "--time-scale", "20", "--out", out,
                                     "--no-progress"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            deadline = time.monotonic() + 60
            while _stored_holds(url) < 4 and time.monotonic() < deadline:
                time.sleep(0.1)
            server.kill()                                     # SIGKILL to the postmaster and every backend
            killed_at = local_counts(out)["holds"]
            while local_counts(out)["holds"] < killed_at + 4 and proc.poll() is None:
                time.sleep(0.1)
            server.start()                                    # crash recovery, same port
            _, err = proc.communicate(timeout=90)
        print("\n".join(log))
        assert proc.returncode == 0, err                      # the session went on and finished locally
        assert mirror.outcome.lost_connection >= 1 and mirror.outcome.complete, log
        assert any("cannot be reached" in line and "recording locally" in line for line in log), log
        assert any("is back" in line for line in log), log
        assert stored_counts(url, out.name) == local_counts(out)
        again = rig("push", out, "--store", url, "--rig", "r-kill")
        assert again.returncode == 0 and "up to date" in again.stdout, again.stdout + again.stderr
        with psycopg.connect(url) as conn:
            assert conn.execute("SELECT status, holds FROM sessions").fetchone() == ("complete", 20)
    finally:
        server.destroy()


def test_a_mirror_that_cannot_reach_the_store_says_so_and_push_finishes_later(tmp_path, pg_url):
    folder, = make_archive(tmp_path, [dict(unit="U-5", rig="r1", start_utc="2026-03-08T09:00:00.000Z")])
    log: list[str] = []
    dead = f"postgresql://rig@127.0.0.1:{free_port()}/lab"
    with live_mirror(folder, dead, echo=log.append, final_push_s=1.0) as mirror:
        time.sleep(0.5)
    assert not mirror.outcome.complete
    assert any("cannot be reached" in line for line in log) and "rig push" in log[-1], log
    done = rig("push", folder, "--store", pg_url)
    assert done.returncode == 0
    assert stored_counts(pg_url, folder.name) == local_counts(folder)


def test_a_read_only_database_stops_the_mirror_with_the_reason(tmp_path, pg_server, pg_url):
    folder, = make_archive(tmp_path, [dict(unit="U-6", rig="r1", start_utc="2026-03-09T09:00:00.000Z")])
    pg_server.sql(f"ALTER DATABASE {pg_url.rsplit('/', 1)[1]} SET default_transaction_read_only = on")
    log: list[str] = []
    mirror = SessionMirror(folder, pg_url, echo=log.append)
    stop = threading.Event()
    started = time.monotonic()
    outcome = mirror.run(stop)
    assert time.monotonic() - started < 10                 # not retried forever: waiting will not help
    assert not outcome.complete and "read-only" in outcome.problem, log
