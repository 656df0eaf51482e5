"""A writer killed with SIGKILL leaves a session that opens cleanly with every committed hold intact."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from synthetic_holds import hold_arrays, move_arrays

from rig.store import SESSION_FILE, SessionStore

HERE = Path(__file__).parent
REPO = HERE.parents[1]


def _start_child(folder: Path, *args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), str(HERE)])}
    return subprocess.Popen([sys.executable, str(HERE / "append_until_killed.py"), str(folder), *args],
                            stdout=subprocess.PIPE, text=True, env=env)


def _kill(child: subprocess.Popen) -> list[str]:
    child.send_signal(signal.SIGKILL)
    out, _ = child.communicate(timeout=10)
    assert child.returncode == -signal.SIGKILL
    return out.split("\n")


def _assert_hold_intact(data, step: int) -> None:
    expected = hold_arrays(step)
    rows = np.flatnonzero(~data.is_move & (data.step == step))
    np.testing.assert_array_equal(data.t[rows], expected["t"])
    for sensor, y in expected["samples"].items():
        np.testing.assert_array_equal(data.raw[sensor][rows], y)
    np.testing.assert_array_equal(data.q_ref[rows], expected["q_ref"])


def _wait_for_line(child: subprocess.Popen, wanted: str, timeout_s: float = 20.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        line = child.stdout.readline()
        if line.strip() == wanted:
            return
        if not line and child.poll() is not None:
            break
    raise AssertionError(f"child never printed {wanted!r}")


def test_kill_inside_hold_transaction_leaves_that_hold_out(tmp_path):
    """The child is stopped after the segment row of hold 3 is inserted but before its COMMIT."""
    folder = tmp_path / "session"
    child = _start_child(folder, "stall", "3")
    _wait_for_line(child, "stalled")
    _kill(child)

    with SessionStore.open(folder) as store:
        assert store.completed_holds() == [0, 1, 2]
        data = store.to_session_data()
    for step in (0, 1, 2):
        _assert_hold_intact(data, step)
    assert set(data.step[data.is_move]) == {0, 1}     # move 2 is committed with hold 3, so it went with it
    db = sqlite3.connect(folder / SESSION_FILE)
    assert db.execute("SELECT count(*) FROM segment WHERE step = 3").fetchone() == (0,)
    assert db.execute("SELECT count(*) FROM array WHERE segment_id NOT IN (SELECT id FROM segment)").fetchone() == (0,)


@pytest.mark.parametrize("seed", range(4))
def test_kill_at_random_moment(tmp_path, seed):
    folder = tmp_path / "session"
    child = _start_child(folder, "loop")
    _wait_for_line(child, "committed 0")
    time.sleep(np.random.default_rng(seed).uniform(0.0, 0.3))
    lines = _kill(child)
    printed = [int(line.split()[1]) for line in lines if line.startswith("committed")]

    with SessionStore.open(folder) as store:
        holds = store.completed_holds()
        data = store.to_session_data()
    db = sqlite3.connect(folder / SESSION_FILE)
    assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    n_hold_segments = db.execute("SELECT count(*) FROM segment WHERE phase = 'hold'").fetchone()[0]

    last_printed = printed[-1] if printed else 0
    assert holds == list(range(len(holds)))                      # no gaps
    assert n_hold_segments == len(holds)                          # none duplicated
    assert last_printed + 1 <= len(holds) <= last_printed + 2     # a commit may precede its print
    for step in holds:
        _assert_hold_intact(data, step)
    moves = sorted(set(data.step[data.is_move]))
    assert moves == holds[:-1]                                    # every move with the hold it leads to
    for step in moves:
        rows = np.flatnonzero(data.is_move & (data.step == step))
        np.testing.assert_array_equal(data.raw["gyro"][rows], move_arrays(step)["samples"]["gyro"])
