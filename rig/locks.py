"""One process per session folder, per turntable and per chamber: exclusive locks that name their holder.

A lock is `fcntl.flock` on an open file, so the kernel releases it when the holding process dies however it
dies (SIGKILL, power-off of a USB host, a crash): a stale lock is never a problem, the next process simply
takes it. The file also carries who holds it (pid, host, command, since when) so a refusal can say who to ask;
that text is only informative, the flock decides.

Session folders lock `FOLDER/session.lock`. Turntable links lock a file named after the link's address (the
host and port, or the serial device) in the runtime lock folder: `$RIG_LOCK_DIR`, else `/run/lock/rig`
when writable, else `<tmp>/rig-locks`.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import errno
import fcntl
import hashlib
import json
import os
import re
import socket
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import urlsplit

from rig.errors import Busy, InputError

SESSION_LOCK = "session.lock"


class LockBusy(Busy):
    def __init__(self, what: str, path: Path, holder: dict) -> None:
        self.what, self.path, self.holder = what, path, holder
        super().__init__(f"{what} is in use by {describe_holder(holder)} (lock {path}); wait for it to end "
                         "or stop that process")


def describe_holder(holder: dict) -> str:
    if not holder:
        return "another process (it has not said which yet)"
    pid, host = holder.get("pid", "?"), holder.get("host", "?")
    command, since = holder.get("command", "?"), holder.get("since", "?")
    return f"pid {pid} on {host} ({command}) since {since}"


@contextlib.contextmanager
def exclusive_lock(path: Path, what: str) -> Iterator[Path]:
    """Hold an exclusive lock on `path` (created if needed) for the `with` block; LockBusy if another process
    holds it. The file is left in place afterwards: deleting a lock file races with a process opening it."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    except OSError as exc:
        raise InputError(f"{what}: cannot create the lock file {path}: {exc.strerror}") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise InputError(f"{what}: cannot lock {path}: {exc.strerror}") from None
            raise LockBusy(what, path, _read_holder(fd)) from None
        _write_holder(fd)
        try:
            yield path
        finally:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


def session_lock(folder: Path) -> contextlib.AbstractContextManager[Path]:
    """The lock of a session folder (which must exist)."""
    return exclusive_lock(Path(folder) / SESSION_LOCK, f"session {folder}")


def lock_dir() -> Path:
    """The folder of the turntable locks, made if needed (world-writable with the sticky bit, like /tmp, so
    that two users of one machine see each other's locks)."""
    given = os.environ.get("RIG_LOCK_DIR")
    candidates = [Path(given)] if given else [Path("/run/lock/rig"), Path(tempfile.gettempdir()) / "rig-locks"]
    last: OSError | None = None
    for folder in candidates:
        try:
            folder.mkdir(parents=True, exist_ok=True)
            if not given:
                with contextlib.suppress(OSError):
                    os.chmod(folder, 0o1777)
            if os.access(folder, os.W_OK | os.X_OK):
                return folder
        except OSError as exc:
            last = exc
    raise InputError(f"no writable folder for the turntable locks ({', '.join(map(str, candidates))}"
                     + (f": {last.strerror}" if last else "") + "); set RIG_LOCK_DIR")


def table_key(url: str) -> str | None:
    """What identifies the table behind `url`: 'host:port' or the serial device; None for a private table
    (port 0: a simulated table on an ephemeral port that no other process can reach by that URL)."""
    parts = urlsplit(url.strip())
    if parts.netloc:
        host = (parts.hostname or "").lower()
        try:
            port = parts.port
        except ValueError:
            port = None
        if port == 0:
            return None
        return f"{host}:{port}" if port is not None else host
    return parts.path or url


def table_lock(url: str) -> contextlib.AbstractContextManager:
    """The lock of the turntable at `url` (a no-op for a private simulated table)."""
    return _device_lock("table", "turntable", url)


def chamber_lock(url: str) -> contextlib.AbstractContextManager:
    """The lock of the thermal chamber at `url` (a no-op for a private simulated chamber)."""
    return _device_lock("chamber", "chamber", url)


def _device_lock(prefix: str, what: str, url: str) -> contextlib.AbstractContextManager:
    key = table_key(url)
    if key is None:
        return contextlib.nullcontext()
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", key).strip("_")[:60]
    digest = hashlib.sha1(key.encode()).hexdigest()[:8]
    return exclusive_lock(lock_dir() / f"{prefix}-{slug}-{digest}.lock", f"{what} {key}")


def _read_holder(fd: int) -> dict:
    try:
        text = os.pread(fd, 4096, 0).decode("utf-8", "replace")
        holder = json.loads(text) if text.strip() else {}
        return holder if isinstance(holder, dict) else {}
    except (OSError, ValueError):
        return {}


def _command_line() -> str:
    if not sys.argv:
        return "python"
    program = Path(sys.argv[0])
    name = "rig" if program.parts[-2:] == ("rig", "cli.py") else program.name
    return " ".join([name, *sys.argv[1:]])[:200]


def _write_holder(fd: int) -> None:
    holder = {"pid": os.getpid(), "host": socket.gethostname(), "command": _command_line(),
              "since": dt.datetime.now().astimezone().isoformat(timespec="seconds")}
    data = (json.dumps(holder) + "\n").encode()
    with contextlib.suppress(OSError):
        os.ftruncate(fd, 0)
        os.pwrite(fd, data, 0)
