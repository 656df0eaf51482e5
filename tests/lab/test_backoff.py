"""The mirror's manners towards the server: a wrong password is tried once and named in one line; a database
that is away is asked again at most once a second per rig, on a growing, jittered schedule, while the session
runs and after it; everything is stored once it is back. Every attempt is counted by a relay in front of the
real server (`proxy.CountingProxy`), one per rig."""

from __future__ import annotations

import random
import threading
import time

import pytest

from rig.lab.mirror import MAX_BACKOFF_S, Backoff, SessionMirror

from .conftest import RIG, make_archive, no_traceback, rig
from .pgserver import PgServer
from .proxy import CountingProxy
from .test_push import local_counts, stored_counts


def test_the_backoff_grows_to_its_cap_with_jitter_and_never_tries_twice_a_second():
    now = [0.0]
    schedules = []
    for seed in range(20):
        backoff = Backoff(rng=random.Random(seed), clock=lambda: now[0])
        times = []
        for _ in range(12):
            now[0] += backoff.ready_in()
            backoff.attempt()
            times.append(now[0])
            backoff.failed()
        schedules.append(times)
    gaps = [b - a for times in schedules for a, b in zip(times, times[1:])]
    assert min(gaps) >= 1.0 and max(gaps) <= MAX_BACKOFF_S                  # at most one attempt a second
    late = sorted(times[-1] - times[-2] for times in schedules)       # after 11 failures: the cap's jitter
    assert late[0] >= MAX_BACKOFF_S / 2 and late[-1] - late[0] > 1.0   # rigs cut off together come back apart


@pytest.fixture
def password_role(pg_server, pg_url, tmp_path, monkeypatch):
    """A login role `rig_pw` whose password file (PGPASSFILE) holds a wrong password."""
    pg_server.sql("DO $$ BEGIN IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = 'rig_pw') THEN "
                  "CREATE ROLE rig_pw LOGIN PASSWORD 'the-right-one'; END IF; END $$")
    passfile = tmp_path / "pgpass"
    passfile.write_text("127.0.0.1:*:*:rig_pw:not-the-right-one\n")
    passfile.chmod(0o600)
    monkeypatch.setenv("PGPASSFILE", str(passfile))
    return pg_url.rsplit("/", 1)[1]


def test_a_wrong_password_is_one_attempt_one_line_and_exit_2(tmp_path, pg_server, password_role):
    folder, = make_archive(tmp_path, [dict(unit="U-PW", rig="r1", start_utc="2026-03-10T09:00:00.000Z")])
    proxy = CountingProxy(pg_server.port)
    try:
        url = proxy.url(password_role, "rig_pw")
        started = time.monotonic()
        followed = rig("push", folder, "--store", url, "--follow", timeout=60)
        no_traceback(followed)
        assert followed.returncode == 2, followed.stderr
        assert len(proxy.attempts) == 1
        assert time.monotonic() - started < 20
        lines = [line for line in followed.stderr.splitlines() if not line.startswith("following ")]
        assert len(lines) == 1 and "password authentication failed" in lines[0] and "rig push" in lines[0], lines
        assert "not-the-right-one" not in followed.stderr

        proxy.attempts.clear()
        out = tmp_path / "live"
        session = rig("calibrate", "--sim", "--time-scale", "50", "--out", out, "--no-progress", "--store", url,
                      timeout=120)
        no_traceback(session)
        assert session.returncode == 0, session.stderr            # the session is the rig's: it went well
        assert len(proxy.attempts) == 1
        store_lines = [line for line in session.stderr.splitlines() if "127.0.0.1" in line]
        assert len(store_lines) == 1 and "password authentication failed" in store_lines[0], session.stderr
    finally:
        proxy.close()


def test_a_database_away_is_asked_at_most_once_a_second_per_rig_and_gets_everything_back(tmp_path):
    server = PgServer()
    server.start()
    proxies = []
    try:
        url_db = server.createdb("lab")
        db = url_db.rsplit("/", 1)[1]
        folders = make_archive(tmp_path, [dict(unit=f"U-D{k}", rig=f"r{k}", name=f"rig{k}",
                                               start_utc=f"2026-03-11T0{k}:00:00.000Z") for k in range(3)])
        proxies = [CountingProxy(server.port) for _ in folders]
        server.kill()
        down_at = time.monotonic()
        mirrors, threads, stop = [], [], threading.Event()
        for folder, proxy in zip(folders, proxies):
            mirror = SessionMirror(folder, proxy.url(db, "rig"), echo=lambda _: None, wait_down_s=60)
            mirrors.append(mirror)
            threads.append(threading.Thread(target=mirror.run, args=(stop,)))
        stop.set()                          # the sessions have ended: the mirrors are on their own
        for t in threads:
            t.start()
        time.sleep(8)
        server.start()
        back_at = time.monotonic()
        for t in threads:
            t.join(60)
        for mirror, folder, proxy in zip(mirrors, folders, proxies):
            assert mirror.outcome.complete, mirror.outcome.log
            assert stored_counts(url_db, folder.name) == local_counts(folder)
            gaps = [b - a for a, b in zip(proxy.attempts, proxy.attempts[1:])]
            assert min(gaps) >= 1.0, proxy.attempts                          # at most one a second
            while_down = proxy.between(down_at, back_at)
            assert 2 <= len(while_down) <= 5, while_down                      # 0, 1, 1.5-3, 3.5-7 s: growing
            assert proxy.attempts[-1] - back_at < MAX_BACKOFF_S / 2 + 5
    finally:
        for proxy in proxies:
            proxy.close()
        server.destroy()
