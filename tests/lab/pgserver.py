"""A real PostgreSQL server for the lab tests and benchmarks, from Debian's package.

The data directory is under a fresh temporary folder, the server listens on loopback only, on a free port,
with its socket in that folder. It trusts the superuser `rig` on loopback (test data only); every other role
logs in with a password (SCRAM), so that the tests of credentials, roles and the password file meet the
authentication a lab's server asks for. Run as root (CI is), the
server runs as the `postgres` user the Debian package creates (initdb refuses root). `kill()` is a crash:
SIGKILL to the postmaster and every backend it started; `start()` then runs crash recovery.
"""

from __future__ import annotations

import glob
import os
import pwd
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

import psycopg

SUPERUSER = "rig"


def pg_bin() -> Path:
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"), key=lambda p: int(p.split("/")[4]))
    if os.environ.get("RIG_PG_BIN"):
        return Path(os.environ["RIG_PG_BIN"])
    if not found:
        raise RuntimeError("PostgreSQL is not installed: scripts/test.sh installs it (apt-get install -y postgresql)")
    return Path(found[-1]).parent


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class PgServer:
    def __init__(self, fsync: bool = False) -> None:
        self.bin = pg_bin()
        self.root = Path(tempfile.mkdtemp(prefix="rig-pg-"))
        self.data = self.root / "data"
        self.port = free_port()
        self.fsync = fsync
        self.as_user: list[str] = []
        if os.geteuid() == 0:
            user = pwd.getpwnam("postgres")          # made by Debian's postgresql package
            os.chown(self.root, user.pw_uid, user.pw_gid)
            os.chmod(self.root, 0o700)
            self.as_user = ["runuser", "-u", "postgres", "--"]
        self._run(["initdb", "-D", str(self.data), "-U", SUPERUSER, "--auth=trust", "-E", "UTF8", "--no-sync"])
        self.write_hba(f"host all {SUPERUSER} 127.0.0.1/32 trust\nhost all all 127.0.0.1/32 scram-sha-256\n")

    def write_hba(self, host_lines: str) -> None:
        """pg_hba.conf: local (socket) connections trusted, then `host_lines`; a running server reloads it."""
        (self.data / "pg_hba.conf").write_text("local all all trust\n" + host_lines)
        if (self.data / "postmaster.pid").exists():
            self._run(["pg_ctl", "-D", str(self.data), "reload"])

    def _run(self, args: list[str], check: bool = True) -> subprocess.CompletedProcess:
        cmd = [*self.as_user, str(self.bin / args[0]), *args[1:]]
        done = subprocess.run(cmd, capture_output=True, text=True, cwd=self.root)
        if check and done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}\n"
                               f"{self.log_tail()}")
        return done

    def log_tail(self, n: int = 20) -> str:
        log = self.root / "server.log"
        return "\n".join(log.read_text(errors="replace").splitlines()[-n:]) if log.exists() else ""

    def start(self, *settings: str) -> None:
        """Start the server; `settings` are more `name=value` server settings (e.g. `log_connections=on`)."""
        options = (f"-p {self.port} -k {self.root} -c listen_addresses=127.0.0.1 -c max_connections=200"
                   + ("" if self.fsync else " -c fsync=off") + "".join(f" -c {s}" for s in settings))
        self._run(["pg_ctl", "-D", str(self.data), "-l", str(self.root / "server.log"), "-w", "-t", "60",
                   "-o", options, "start"])

    def stop(self) -> None:
        self._run(["pg_ctl", "-D", str(self.data), "-m", "fast", "-w", "stop"], check=False)

    def pids(self) -> list[int]:
        """The postmaster and its children (the backends and helpers it started)."""
        pidfile = self.data / "postmaster.pid"
        if not pidfile.exists():
            return []
        master = int(pidfile.read_text().split()[0])
        children = []
        for stat in glob.glob("/proc/[0-9]*/stat"):
            try:
                fields = Path(stat).read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == master:
                children.append(int(stat.split("/")[2]))
        return [master, *children]

    def kill(self) -> None:
        """A crash: SIGKILL to every process of the server, then wait until they are gone."""
        pids = self.pids()
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(Path(f"/proc/{p}").exists() and _alive(p) for p in pids):
            time.sleep(0.05)
        if pids and not any(_alive(p) for p in pids):
            # A killed postmaster is a zombie until its parent (init here) reaps it, and a zombie still answers
            # kill(pid, 0): the restart would take its lock files for a live server. Dead is dead: drop them, the
            # data folder's and the Unix socket's (the second failed a CI run once the first was handled).
            (self.data / "postmaster.pid").unlink(missing_ok=True)
            for name in (f".s.PGSQL.{self.port}.lock", f".s.PGSQL.{self.port}"):
                (self.root / name).unlink(missing_ok=True)

    def url(self, db: str = "postgres", user: str = SUPERUSER) -> str:
        return f"postgresql://{user}@127.0.0.1:{self.port}/{db}"

    def sql(self, statement: str, db: str = "postgres", args=None) -> list[tuple]:
        with psycopg.connect(self.url(db), autocommit=True) as conn:
            cur = conn.execute(statement, args)
            return cur.fetchall() if cur.description else []

    def createdb(self, name: str) -> str:
        self.sql(f'CREATE DATABASE "{name}"')
        return self.url(name)

    def destroy(self) -> None:
        self.stop()
        self.kill()
        shutil.rmtree(self.root, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"
