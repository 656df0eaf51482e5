"""The lab's tests: one real PostgreSQL server for the whole run (a fresh database per test), one headless
Chromium, `rig serve` started as a user would, and archives of real session folders."""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from .archive import simulated, small_plan, write_session
from .browser import start_browser, stop_browser
from .pgserver import PgServer, free_port

RIG = [sys.executable, "-m", "rig.cli"]
_names = itertools.count()


@pytest.fixture(autouse=True)
def private_lock_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("RIG_LOCK_DIR", str(tmp_path / "locks"))


@pytest.fixture(scope="session")
def pg_server():
    server = PgServer()
    server.start()
    yield server
    server.destroy()


@pytest.fixture
def pg_url(pg_server) -> str:
    """A fresh, empty database on the shared server."""
    return pg_server.createdb(f"lab_{os.getpid()}_{next(_names)}")


@pytest.fixture(scope="session")
def browser():
    driver = start_browser()
    yield driver
    stop_browser(driver)


def rig(*args, timeout: float = 120, **kw) -> subprocess.CompletedProcess:
    """`rig ARGS` as a user runs it; the output checked for tracebacks by the callers' helper."""
    return subprocess.run([*RIG, *map(str, args)], capture_output=True, text=True, timeout=timeout, **kw)


def no_traceback(done: subprocess.CompletedProcess) -> None:
    assert "Traceback" not in done.stderr and "Traceback" not in done.stdout, done.stderr


class Served:
    def __init__(self, store: str) -> None:
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.proc = subprocess.Popen([*RIG, "serve", "--store", store, "--port", str(self.port)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 30
        while True:
            try:
                urllib.request.urlopen(self.base + "/units", timeout=5).read()
                return
            except (urllib.error.URLError, ConnectionError):
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    out, err = self.proc.communicate(timeout=5) if self.proc.poll() is not None else ("", "")
                    raise RuntimeError(f"rig serve did not start: {err}")
                time.sleep(0.1)

    def get(self, path: str) -> tuple[int, bytes]:
        try:
            with urllib.request.urlopen(self.base + path, timeout=10) as r:
                return r.status, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    def stop(self) -> str:
        self.proc.terminate()
        try:
            _, err = self.proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            _, err = self.proc.communicate()
        return err


@pytest.fixture
def serve():
    started = []

    def start(store: str) -> Served:
        started.append(Served(store))
        return started[-1]

    yield start
    for s in started:
        err = s.stop()
        assert "Traceback" not in err, err


def make_archive(root: Path, sessions: list[dict]) -> list[Path]:
    """Session folders from dicts of write_session's keywords plus unit_seed, noise_seed, effects, plan."""
    folders = []
    for i, spec in enumerate(sessions):
        spec = dict(spec)
        plan = spec.pop("plan", None) or small_plan()
        session = simulated(spec.pop("unit_seed", 5), spec.pop("noise_seed", 100 + i), plan, spec.pop("effects", []))
        folder = root / spec.pop("name", f"s{i:03d}")
        write_session(folder, session, plan=plan, **spec)
        folders.append(folder)
    return folders
