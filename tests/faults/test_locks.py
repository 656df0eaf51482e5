"""One process per session folder and per turntable: a second is refused with the holder named, touching
nothing; a lock of a dead process is taken over."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rig.locks import LockBusy, exclusive_lock, table_key, table_lock

RIG = [sys.executable, "-m", "rig.cli"]
HOLD_LOCK = """
import sys, time
from rig.locks import exclusive_lock, table_lock
lock = table_lock(sys.argv[2]) if sys.argv[1] == "table" else exclusive_lock(sys.argv[2], "test")
with lock:
    print("locked", flush=True)
    time.sleep(600)
"""


def hold_lock_in_child(kind: str, target: str) -> subprocess.Popen:
    child = subprocess.Popen([sys.executable, "-c", HOLD_LOCK, kind, target], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "locked"
    return child


def test_a_second_holder_is_refused_with_the_first_named(tmp_path):
    with exclusive_lock(tmp_path / "x.lock", "session X"):
        with pytest.raises(LockBusy) as err:
            with exclusive_lock(tmp_path / "x.lock", "session X"):
                pass
    message = str(err.value)
    assert f"pid {os.getpid()}" in message and "since" in message and "session X is in use" in message
    with exclusive_lock(tmp_path / "x.lock", "session X"):       # released on exit
        pass


def test_the_lock_of_a_killed_process_is_taken_over(tmp_path):
    path = tmp_path / "x.lock"
    child = hold_lock_in_child("file", str(path))
    with pytest.raises(LockBusy, match=f"pid {child.pid}"):
        with exclusive_lock(path, "test"):
            pass
    child.send_signal(signal.SIGKILL)
    child.wait()
    with exclusive_lock(path, "test"):
        assert f'"pid": {os.getpid()}' in path.read_text()


def test_table_locks_are_keyed_by_the_table_not_the_spelling():
    assert table_key("tcp://LOCALHOST:502") == table_key("tcp://localhost:502") == "localhost:502"
    assert table_key("rtu:///dev/ttyUSB0?baud=115200") == table_key("rtu:///dev/ttyUSB0?baud=9600") == "/dev/ttyUSB0"
    assert table_key("tcp://127.0.0.1:0") is None               # a private simulated table on an ephemeral port


def _events(folder: Path) -> list[tuple]:
    db = sqlite3.connect(folder / "session.sqlite")
    try:
        return db.execute("SELECT id, kind, message FROM event ORDER BY id").fetchall()
    finally:
        db.close()


def test_resume_while_the_session_runs_is_refused_and_touches_nothing(tmp_path):
    out = tmp_path / "live"
    first = subprocess.Popen([*RIG, "calibrate", "--sim", "--no-progress", "--time-scale", "25", "--orientations",
                              "9", "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (out / "session.sqlite").exists():
        time.sleep(0.05)
    time.sleep(1.0)
    before = _events(out)
    second = subprocess.run([*RIG, "resume", str(out), "--no-progress"], capture_output=True, text=True, timeout=60)
    assert second.returncode == 4, second.stderr
    assert f"pid {first.pid}" in second.stderr and "rig calibrate --sim" in second.stderr
    assert "Traceback" not in second.stderr
    assert not [e for e in _events(out) if e not in before and "failed" in e[2]]
    out_first, err_first = first.communicate(timeout=120)
    assert first.returncode == 0, err_first
    assert [e for e in _events(out) if e[1] == "status"][-1][2] == "complete"


def test_table_commands_and_sessions_are_refused_while_another_process_drives_the_table(tmp_path):
    from fixtures.turntable import FakeTurntable, TurntableServer
    from rig.clock import RealClock

    with TurntableServer(FakeTurntable(clock=RealClock())) as server:
        holder = hold_lock_in_child("table", server.url)
        try:
            moved = subprocess.run([*RIG, "table", "--url", server.url, "move", "1", "-1"], capture_output=True,
                                   text=True, timeout=60)
            assert moved.returncode == 4, moved.stderr
            assert f"pid {holder.pid}" in moved.stderr and "turntable" in moved.stderr
            stopped = subprocess.run([*RIG, "table", "--url", server.url, "stop"], capture_output=True, text=True,
                                     timeout=60)
            assert stopped.returncode == 0, stopped.stderr             # stopping never waits for a lock
            cfg = tmp_path / "rig.toml"
            cfg.write_text(f'[turntable]\nurl = "{server.url}"\n')
            session = subprocess.run([*RIG, "calibrate", "--sim", "--config", str(cfg), "--no-progress",
                                      "--out", str(tmp_path / "s")], capture_output=True, text=True, timeout=60)
            assert session.returncode == 4, session.stderr
            assert not (tmp_path / "s" / "session.sqlite").exists()
        finally:
            holder.kill()
            holder.wait()
        with table_lock(server.url):
            pass
