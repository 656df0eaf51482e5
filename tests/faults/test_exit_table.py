"""One exit-code table, true for every command: each code of `rig.exits.EXIT_TABLE` made by a real `rig`
invocation (several commands per code), its line said without a traceback, and the session's stored status the
table's; the reference page (docs/reference/exit-codes.md) is generated from the same table."""

from __future__ import annotations

import glob
import resource
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import time
from importlib import resources
from pathlib import Path

import pytest

from rig.exits import EXIT_TABLE
from rig.store import SessionStore

RIG = [sys.executable, "-m", "rig.cli"]


def rig(*args, timeout=300, **kw) -> subprocess.CompletedProcess:
    done = subprocess.run([*RIG, *map(str, args)], capture_output=True, text=True, timeout=timeout, **kw)
    assert "Traceback" not in done.stdout + done.stderr, done.stderr
    return done


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def status(folder: Path) -> str:
    with SessionStore.open(folder) as store:
        return store.status[0]


def holds_recorded(folder: Path) -> int:
    """Holds a session has stored so far (0 before its store exists): read as another process would."""
    if not (folder / "session.sqlite").exists():
        return 0
    try:
        with sqlite3.connect(f"file:{folder / 'session.sqlite'}?mode=ro", uri=True) as db:
            return db.execute("SELECT count(*) FROM segment WHERE phase = 'hold'").fetchone()[0]
    except sqlite3.OperationalError:     # the store being created
        return 0


_FINISHED: list[Path] = []


def session(folder: Path) -> Path:
    """A finished simulated session in `folder`: recorded once per test process, then copied, since the cases
    that start from one ask about the command they run on it, not about the session."""
    if not _FINISHED:
        done = rig("calibrate", "--sim", "--orientations", "9", "--time-scale", "50", "--no-progress", "--out",
                   folder)
        assert done.returncode == 0, done.stderr
        _FINISHED.append(folder.parent / "finished")
        shutil.copytree(folder, _FINISHED[0])
        return folder
    shutil.copytree(_FINISHED[0], folder)
    return folder


class Background:
    """A `rig` command left running (a server, a session), ended with SIGTERM at the end of the case."""

    def __init__(self, *args) -> None:
        self.proc = subprocess.Popen([*RIG, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True)

    def __enter__(self) -> "Background":
        return self

    def __exit__(self, *exc) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
        self.proc.communicate(timeout=60)


def wait_for(test, what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not test():
        assert time.monotonic() < deadline, f"{what} did not happen in {timeout} s"
        time.sleep(0.05)


def listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def sim_turntable() -> tuple[Background, int]:
    port = free_port()
    server = Background("sim-turntable", "--port", port, "--time-scale", "50")
    wait_for(lambda: listening(port), "sim-turntable listening")
    return server, port


# -- the cases: (code, name) -> a function of tmp_path that runs the command and checks what it said ------------
CASES = {}


def case(code: int, name: str):
    def register(f):
        CASES[(code, name)] = f
        return f
    return register


@case(0, "calibrate --sim passes")
def _(tmp):
    done = rig("calibrate", "--sim", "--orientations", "9", "--time-scale", "50", "--no-progress", "--out", tmp / "s")
    assert done.returncode == 0 and "verdict: PASS" in done.stdout, done.stderr
    assert status(tmp / "s") == "complete"


@case(0, "export of a finished session")
def _(tmp):
    done = rig("export", session(tmp / "s"), "--to", tmp / "e")
    assert done.returncode == 0 and "warning" not in done.stderr, done.stderr


@case(1, "calibrate --sim with a limit the unit cannot meet")
def _(tmp):
    text = resources.files("rig.configs").joinpath("sim.toml").read_text()
    tight = text.replace("[limits.gyro]\nresidual_rms_max = 0.02", "[limits.gyro]\nresidual_rms_max = 0.00001")
    assert tight != text
    (tmp / "tight.toml").write_text(tight)
    done = rig("calibrate", "--sim", "--config", tmp / "tight.toml", "--orientations", "9", "--time-scale", "50",
               "--no-progress", "--out", tmp / "s")
    assert done.returncode == 1 and "verdict: FAIL" in done.stderr and "gyro residual_rms" in done.stderr
    assert status(tmp / "s") == "rejected"


@case(2, "table move beyond the table's limits")
def _(tmp):
    server, port = sim_turntable()
    with server:
        done = rig("table", "--url", f"tcp://127.0.0.1:{port}", "move", "400", "-30")
    assert done.returncode == 2 and "OUT_OF_LIMITS" in done.stderr, done.stderr


@case(2, "calibrate --from a session into itself without --force")
def _(tmp):
    folder = session(tmp / "s")
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.suffix in (".json", ".md")}
    done = rig("calibrate", "--from", folder, "--out", folder)
    assert done.returncode == 2 and "--force" in done.stderr, done.stderr
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.suffix in (".json", ".md")} == before
    forced = rig("calibrate", "--from", folder, "--out", folder, "--force", "--settle-s", "1.0")
    assert forced.returncode == 0 and "report.md again" in forced.stdout, forced.stderr
    report = (folder / "report.md").read_text()
    cal = (folder / "calibration.json").read_text()
    assert before["calibration.json"].decode() != cal and before["report.md"].decode() != report


@case(2, "import csv with seconds given as ms")
def _(tmp):
    rows = ["t,ax,ay,az"] + [f"{i / 100:.2f},0.01,0.02,9.8" for i in range(200)]
    (tmp / "log.csv").write_text("\n".join(rows) + "\n")
    done = rig("import", "csv", tmp / "log.csv", "--time", "t", "--time-unit", "ms", "--accel", "ax,ay,az",
               "--units", "accel=m/s^2", "--out", tmp / "i")
    assert done.returncode == 2 and "--time-unit s" in done.stderr and not (tmp / "i" / "samples.csv").exists()


@case(2, "a store URL carrying a password")
def _(tmp):
    done = rig("push", session(tmp / "s"), "--store", "postgresql://rig:secret@127.0.0.1:1/lab")
    assert done.returncode == 2 and "password file" in done.stderr and "secret" not in done.stderr, done.stderr


@case(2, "serve beyond loopback without users and TLS")
def _(tmp):
    (tmp / "store").mkdir()
    done = rig("serve", "--store", tmp / "store", "--host", "0.0.0.0", "--port", free_port())
    assert done.returncode == 2 and "--users" in done.stderr, done.stderr


@case(3, "a session that meets a file-size limit")
def _(tmp):
    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (450_000, 450_000))

    done = rig("calibrate", "--sim", "--orientations", "12", "--time-scale", "50", "--no-progress", "--out",
               tmp / "s", preexec_fn=limit)
    assert done.returncode == 3 and "file-size limit" in done.stderr, done.stderr
    assert status(tmp / "s") == "failed"


@case(3, "push to a store that is away")
def _(tmp):
    done = rig("push", session(tmp / "s"), "--store", f"postgresql://rig@127.0.0.1:{free_port()}/lab")
    assert done.returncode == 3 and "cannot be reached" in done.stderr, done.stderr


@case(3, "table status with nothing at its address")
def _(tmp):
    done = rig("table", "--url", f"tcp://127.0.0.1:{free_port()}", "--timeout", "0.2", "status", timeout=120)
    assert done.returncode == 3, done.stderr


@case(4, "a second calibrate into a folder another process records into")
def _(tmp):
    out = tmp / "s"
    with Background("calibrate", "--sim", "--orientations", "9", "--time-scale", "1", "--no-progress", "--out",
                    out) as first:
        wait_for(lambda: holds_recorded(out) > 0, "the first session's first hold", timeout=120)
        done = rig("calibrate", "--sim", "--orientations", "9", "--no-progress", "--out", out)
        exported = rig("export", out, "--to", tmp / "e")
        calibrated = rig("calibrate", "--from", out, "--out", tmp / "c")
        into_it = rig("calibrate", "--from", tmp / "e", "--out", out)
        still_recording = first.proc.poll() is None
        first.proc.send_signal(signal.SIGTERM)
        first.proc.wait(timeout=120)
    assert still_recording, "the first session ended before the others were tried: the case tested nothing"
    assert done.returncode == 4 and f"pid {first.proc.pid}" in done.stderr, done.stderr
    assert "rig resume" not in done.stderr
    assert exported.returncode == 0 and "still being recorded" in exported.stderr, exported.stderr
    assert "still being recorded" in calibrated.stderr and "not the whole session" in calibrated.stderr
    assert into_it.returncode == 4 and "being recorded there" in into_it.stderr, into_it.stderr
    assert first.proc.returncode == 143 and status(out) == "aborted", (first.proc.returncode, status(out))


@case(4, "sim-turntable on a port another process holds")
def _(tmp):
    server, port = sim_turntable()
    with server:
        done = rig("sim-turntable", "--port", port)
    assert done.returncode == 4 and f"pid {server.proc.pid}" in done.stderr, done.stderr


@case(4, "serve on a port another process holds")
def _(tmp):
    server, port = sim_turntable()
    (tmp / "store").mkdir()
    with server:
        done = rig("serve", "--store", tmp / "store", "--port", port)
    assert done.returncode == 4 and f"pid {server.proc.pid}" in done.stderr, done.stderr


@case(70, "a bug in a command")
def _(tmp):
    folder = session(tmp / "s")
    before = set(glob.glob("/tmp/rig-error-*.log"))
    planted = ("import sys, rig.io.session_writer as writer\n"
               "def write_session(*args, **kwargs):\n    return 1 / 0\n"
               "writer.write_session = write_session\n"
               "from rig.cli import main\nmain(sys.argv[1:])\n")
    done = subprocess.run([sys.executable, "-c", planted, "export", str(folder), "--to", str(tmp / "e")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 70, done.stderr
    assert "Traceback" not in done.stderr and "internal error" in done.stderr and "ZeroDivisionError" in done.stderr
    written = set(glob.glob("/tmp/rig-error-*.log")) - before
    assert len(written) == 1 and "ZeroDivisionError" in Path(written.pop()).read_text()


for _signal in (signal.SIGHUP, signal.SIGINT, signal.SIGTERM):
    def _stopped(tmp, sig=_signal):
        out = tmp / "s"
        with Background("calibrate", "--sim", "--orientations", "9", "--time-scale", "5", "--no-progress", "--out",
                        out) as running:
            wait_for(lambda: (out / "session.sqlite").exists() and _holds(out) >= 1, "a hold recorded")
            running.proc.send_signal(sig)
            _, err = running.proc.communicate(timeout=120)
        assert running.proc.returncode == 128 + sig, err
        assert "Traceback" not in err and status(out) == "aborted"
        with SessionStore.open(out) as store:
            assert sig.name in store.status[1]
    case(128 + _signal, f"calibrate stopped by {_signal.name}")(_stopped)


def _holds(folder: Path) -> int:
    try:
        with sqlite3.connect(f"file:{folder}/session.sqlite?mode=ro", uri=True) as db:
            return db.execute("SELECT count(*) FROM segment WHERE phase = 'hold'").fetchone()[0]
    except sqlite3.Error:
        return 0


@pytest.mark.parametrize("code, name", sorted(CASES), ids=[f"{c}-{n}" for c, n in sorted(CASES)])
def test_the_exit_code_of_a_real_invocation(tmp_path, code, name):
    CASES[(code, name)](tmp_path)


def test_every_code_of_the_table_is_made_by_a_real_command():
    assert {c for row in EXIT_TABLE for c in row[0]} == {code for code, _ in CASES}
