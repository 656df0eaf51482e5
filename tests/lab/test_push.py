"""`rig push` into a real PostgreSQL: every row once, however often and however interrupted; conflicts and
faults refused with their reason and a truthful exit code, the session folders untouched."""

from __future__ import annotations

import shutil
import signal
import sqlite3
import time

import numpy as np
import psycopg
import pytest

from rig.lab import push as push_module
from rig.lab.mirror import push_folder
from rig.store import SessionStore

from .archive import simulated, small_plan, write_session
from .conftest import RIG, make_archive, no_traceback, rig


def local_counts(folder) -> dict:
    with sqlite3.connect(f"file:{folder}/session.sqlite?mode=ro", uri=True) as db:
        return {"holds": db.execute("SELECT count(*) FROM segment WHERE phase = 'hold'").fetchone()[0],
                "moves": db.execute("SELECT count(*) FROM segment WHERE phase = 'move'").fetchone()[0],
                "arrays": db.execute("SELECT count(*) FROM array").fetchone()[0],
                "stats": db.execute("SELECT count(*) FROM hold_stat").fetchone()[0],
                "metadata": db.execute("SELECT count(*) FROM metadata").fetchone()[0],
                "events": db.execute("SELECT count(*) FROM event").fetchone()[0]}


def stored_counts(url: str, name: str) -> dict:
    with psycopg.connect(url) as conn:
        sid = conn.execute("SELECT id FROM sessions WHERE name = %s", (name,)).fetchone()[0]
        q = lambda sql: conn.execute(sql, (sid,)).fetchone()[0]       # noqa: E731
        return {"holds": q("SELECT count(*) FROM segments WHERE session_id = %s AND phase = 'hold'"),
                "moves": q("SELECT count(*) FROM segments WHERE session_id = %s AND phase = 'move'"),
                "arrays": q("SELECT count(*) FROM samples WHERE session_id = %s"),
                "stats": q("SELECT count(*) FROM hold_stats WHERE session_id = %s"),
                "metadata": q("SELECT count(*) FROM session_metadata WHERE session_id = %s"),
                "events": q("SELECT count(*) FROM events WHERE session_id = %s")}


def test_push_stores_every_row_once_and_the_same_bytes(tmp_path, pg_url):
    folder, = make_archive(tmp_path, [dict(unit="U-1", rig="r1", start_utc="2026-03-01T09:00:00.000Z")])
    first = rig("push", folder, "--store", pg_url)
    assert first.returncode == 0, first.stderr
    assert "pushed 12 holds, 11 moves" in first.stdout
    again = rig("push", folder, "--store", pg_url)
    assert again.returncode == 0 and "up to date" in again.stdout, again.stdout
    assert stored_counts(pg_url, folder.name) == local_counts(folder)
    with psycopg.connect(pg_url) as conn:
        stored = conn.execute("SELECT a.data FROM samples a JOIN segments g ON g.session_id = a.session_id AND "
                              "g.seq = a.segment_seq WHERE g.phase = 'hold' AND g.step = 3 AND a.name = 'raw:accel'"
                              ).fetchone()[0]
        status, holds, planned, verdict = conn.execute("SELECT status, holds, planned, verdict FROM sessions").fetchone()
        cal = conn.execute("SELECT count(*) FROM calibrations").fetchone()[0]
    with sqlite3.connect(f"file:{folder}/session.sqlite?mode=ro", uri=True) as db:
        local = db.execute("SELECT a.data FROM array a JOIN segment s ON s.id = a.segment_id WHERE s.phase = 'hold' "
                           "AND s.step = 3 AND a.name = 'raw:accel'").fetchone()[0]
    assert bytes(stored) == local
    assert (status, holds, planned, verdict, cal) == ("complete", 12, 12, "PASS", 1)


def test_a_push_cut_off_half_way_is_finished_by_the_next_one(tmp_path, pg_url, monkeypatch):
    folder, = make_archive(tmp_path, [dict(unit="U-2", rig="r1", start_utc="2026-03-02T09:00:00.000Z")])
    monkeypatch.setattr(push_module, "BATCH_BYTES", 1)          # one hold (and its move) per transaction
    calls = {"n": 0}
    original = push_module.Pusher._insert_segments

    def dies_after_four(self, batch):
        calls["n"] += 1
        if calls["n"] == 5:
            raise KeyboardInterrupt("power cut")
        original(self, batch)

    monkeypatch.setattr(push_module.Pusher, "_insert_segments", dies_after_four)
    with pytest.raises(KeyboardInterrupt):
        push_folder(folder, pg_url)
    part = stored_counts(pg_url, folder.name)
    assert part["holds"] == 4 and part["moves"] == 3            # whole holds with their moves, nothing half
    monkeypatch.setattr(push_module.Pusher, "_insert_segments", original)
    result = push_folder(folder, pg_url)
    assert (result.holds, result.moves) == (8, 8)
    assert stored_counts(pg_url, folder.name) == local_counts(folder)


def test_push_all_killed_mid_run_then_again_gives_one_copy_of_everything(tmp_path, pg_url):
    folders = make_archive(tmp_path, [dict(unit=f"U-{i}", rig="r1", start_utc=f"2026-03-03T{i:02d}:00:00.000Z")
                                      for i in range(16)])
    import subprocess

    proc = subprocess.Popen([*RIG, "push", "--all", tmp_path, "--store", pg_url], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    with psycopg.connect(pg_url, autocommit=True) as conn:
        while time.monotonic() < deadline and proc.poll() is None:
            exists = conn.execute("SELECT to_regclass('sessions') IS NOT NULL").fetchone()[0]
            if exists and conn.execute("SELECT count(*) FROM sessions").fetchone()[0] >= 3:
                break
            time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = rig("push", "--all", tmp_path, "--store", pg_url)
    assert done.returncode == 0, done.stderr
    assert "16 session folders" in done.stdout
    for folder in folders:
        assert stored_counts(pg_url, folder.name) == local_counts(folder), folder.name
    with psycopg.connect(pg_url) as conn:
        assert conn.execute("SELECT count(*) FROM sessions").fetchone()[0] == 16


def test_a_copied_folder_is_the_same_session_and_a_diverged_copy_is_refused(tmp_path, pg_url):
    plan = small_plan()
    session = simulated(5, 1, plan)
    a = tmp_path / "a"
    write_session(a, session, unit="U-3", rig="r1", start_utc="2026-03-04T09:00:00.000Z", plan=plan, finish=False)
    b = tmp_path / "elsewhere" / "a-copy"
    shutil.copytree(a, b)
    assert rig("push", a, "--store", pg_url).returncode == 0
    same = rig("push", b, "--store", pg_url)
    assert same.returncode == 0 and "up to date" in same.stdout, same.stdout + same.stderr
    extra = dict(t=np.arange(5) / 50 + 1000.0, samples={"accel": np.ones((5, 3))}, q_ref=np.tile([1.0, 0, 0, 0], (5, 1)),
                 table_deg=np.zeros((5, 2)), commanded_deg=(0, 0), measured_deg=(0, 0))
    with SessionStore.open(a) as store:
        store.append_hold(40, **extra)
    with SessionStore.open(b) as store:
        store.append_hold(41, **{**extra, "samples": {"accel": np.full((5, 3), 2.0)}})
    assert rig("push", a, "--store", pg_url).returncode == 0
    refused = rig("push", b, "--store", pg_url)
    no_traceback(refused)
    assert refused.returncode == 2, refused.stderr
    assert "conflicts with the session stored" in refused.stderr and "hold step 41" in refused.stderr
    with psycopg.connect(pg_url) as conn:
        steps = [r[0] for r in conn.execute("SELECT step FROM segments WHERE phase = 'hold' AND step >= 40")]
    assert steps == [40]


def test_two_rigs_cannot_hold_one_unit_at_once(tmp_path, pg_url):
    first, second, later = make_archive(tmp_path, [
        dict(name="on-r1", unit="GOLD", rig="r1", start_utc="2026-03-05T09:00:00.000Z", finish=False),
        dict(name="on-r2", unit="GOLD", rig="r2", start_utc="2026-03-05T09:00:30.000Z", finish=False),
        dict(name="later-r2", unit="GOLD", rig="r2", start_utc="2026-03-06T09:00:00.000Z")])
    with SessionStore.open(first) as store:           # r1's session is still running: recently active
        store.log_event("note", "still going")
    with sqlite3.connect(first / "session.sqlite") as db:
        db.execute("UPDATE event SET written_utc = strftime('%Y-%m-%dT%H:%M:%fZ', 'now')")
    assert rig("push", first, "--store", pg_url).returncode == 0
    refused = rig("push", second, "--store", pg_url)
    no_traceback(refused)
    assert refused.returncode == 4, refused.stderr
    assert "unit 'GOLD' is claimed by rig 'r1'" in refused.stderr and "on-r1" in refused.stderr
    with SessionStore.open(first) as store:
        store.set_status("complete", "")
    with sqlite3.connect(first / "session.sqlite") as db:   # it ended before the later session started
        db.execute("UPDATE metadata SET value = '\"2026-03-05T10:00:00.000Z\"' WHERE key = 'end_utc'")
    assert rig("push", first, "--store", pg_url).returncode == 0
    accepted = rig("push", later, "--store", pg_url)
    assert accepted.returncode == 0, accepted.stderr


@pytest.mark.parametrize("fault", ["refused", "read_only", "older_schema", "newer_schema"])
def test_a_database_that_cannot_take_the_session_is_named_and_nothing_changes(tmp_path, pg_server, pg_url, fault):
    folder, = make_archive(tmp_path, [dict(unit="U-4", rig="r1", start_utc="2026-03-07T09:00:00.000Z")])
    before = (folder / "session.sqlite").read_bytes()
    url, expect = pg_url, ""
    if fault == "refused":
        from .pgserver import free_port

        url, expect = f"postgresql://rig@127.0.0.1:{free_port()}/lab", "cannot be reached"
    elif fault == "read_only":
        pg_server.sql(f"ALTER DATABASE {pg_url.rsplit('/', 1)[1]} SET default_transaction_read_only = on")
        expect = "read-only"
    else:
        version = 0 if fault == "older_schema" else 99
        with psycopg.connect(pg_url, autocommit=True) as conn:
            conn.execute("CREATE TABLE lab_schema (version integer NOT NULL, created_utc timestamptz)")
            conn.execute("INSERT INTO lab_schema (version) VALUES (%s)", (version,))
        expect = "older than this rig's" if version == 0 else "newer than this rig's"
    done = rig("push", folder, "--store", url)
    no_traceback(done)
    assert done.returncode == 3, done.stderr
    assert expect in done.stderr and "Error:" in done.stderr
    assert (folder / "session.sqlite").read_bytes() == before
    if fault != "refused":
        with psycopg.connect(pg_url) as conn:
            assert conn.execute("SELECT to_regclass('sessions')").fetchone()[0] is None


def test_push_refuses_what_is_not_a_session_or_not_a_database(tmp_path, pg_url):
    (tmp_path / "empty").mkdir()
    done = rig("push", tmp_path / "empty", "--store", pg_url)
    no_traceback(done)
    assert done.returncode == 2 and "not a rig session" in done.stderr
    done = rig("push", tmp_path / "empty", "--store", tmp_path)
    assert done.returncode == 2 and "folder store" in done.stderr
    done = rig("push", tmp_path / "empty", "--store", "postgresql://rig@127.0.0.1:5432/x?sslmode=bogus")
    no_traceback(done)
    assert done.returncode == 2 and "sslmode" in done.stderr, done.stderr     # the URL is the user's to mend
    done = rig("push", tmp_path / "empty", "--store", "postgresql://rig:s3cret@127.0.0.1:5432/x")
    no_traceback(done)
    assert done.returncode == 2 and "password file" in done.stderr and "s3cret" not in done.stderr, done.stderr


def test_rigs_creating_the_tables_at_the_same_moment_all_succeed(pg_url):
    import threading

    from rig.lab.pg import connect

    errors, barrier = [], threading.Barrier(8)

    def one():
        barrier.wait()
        try:
            connect(pg_url).close()
        except Exception as exc:                  # noqa: BLE001 - any failure is the finding
            errors.append(exc)

    threads = [threading.Thread(target=one) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    with psycopg.connect(pg_url) as conn:
        assert conn.execute("SELECT count(*) FROM lab_schema").fetchone()[0] == 1
