"""The SQLite file of a session: created whole or not at all, opened and checked to be a rig session, and
written in explicit transactions whose errors name the file.

SQLite in WAL mode with `synchronous=FULL`, one transaction per hold (with the move that led to it). Why FULL:
in WAL mode NORMAL is already safe against a killed process, but a commit made under NORMAL can still roll back
after a power cut or kernel crash, because the WAL is synced only at checkpoints. A lab bench loses
power; FULL syncs the WAL at every commit, and with one commit per 5 s hold the fsync cost is
irrelevant (benchmarks/store_write_load.py measures it). So a crash of any kind loses at most the
hold in progress and the move into it.
"""

from __future__ import annotations

import os
import sqlite3
from collections.abc import Iterator
from contextlib import closing, contextmanager
from pathlib import Path

from rig.errors import InputError, RigError
from rig.store.metadata_table import insert_metadata
from rig.store.schema import APPLICATION_ID, LAYOUT_VERSION, create_tables
from rig.store.write_errors import why

BUSY_TIMEOUT_S = 5.0
# A session file is built under this suffix and renamed into place once it is a whole session: a create that
# is killed part way (a stop signal at start-up) leaves no file that `rig resume` would refuse as not a session.
PARTIAL_SUFFIX = ".partial"


class SessionStoreError(RigError):
    """A session file cannot be used or written (corrupt, closed, the disk full); names the path."""


class NotASession(SessionStoreError, InputError):
    """The folder given is not a session the rig can open (missing, another program's file, a newer layout)."""


def create_session_file(path: Path, metadata_rows: list[tuple[str, str, str]]) -> sqlite3.Connection:
    """The session file `path` (its folder made if needed) laid out with its first metadata rows, whole or not at
    all, and a connection to it for reading and appending."""
    folder = path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise NotASession(f"{folder}: cannot create the session folder: {exc.strerror}") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise NotASession(f"{folder}: the folder is not writable")
    partial = path.with_name(path.name + PARTIAL_SUFFIX)
    _remove_sqlite_files(partial)          # left by a create that was killed before it finished
    try:
        with closing(_connect(partial, uri=partial.resolve().as_uri())) as conn:
            with transaction(conn, path) as db:     # errors name the session file
                create_tables(db)
                insert_metadata(db, metadata_rows)
        os.replace(partial, path)
    except BaseException:
        _remove_sqlite_files(partial)
        raise
    return _connect(path, uri=path.resolve().as_uri() + "?mode=rw")


def open_session_file(path: Path) -> sqlite3.Connection:
    """A connection for reading and appending to the existing session file `path`, checked to be one."""
    conn = _connect(path, uri=path.resolve().as_uri() + "?mode=rw")
    try:
        _check_file(path, conn)
    except BaseException:
        conn.close()
        raise
    return conn


@contextmanager
def transaction(db: sqlite3.Connection, path: Path) -> Iterator[sqlite3.Connection]:
    """BEGIN IMMEDIATE ... COMMIT, rolled back on any exception; an SQLite error becomes a SessionStoreError
    naming the session file `path` and, where it can, the cause."""
    try:
        db.execute("BEGIN IMMEDIATE")
        yield db
        db.execute("COMMIT")
    except BaseException as exc:
        if db.in_transaction:
            try:
                db.execute("ROLLBACK")
            except sqlite3.Error:
                pass
        if isinstance(exc, sqlite3.Error):
            raise SessionStoreError(f"{path}: could not write the session: {why(exc, path)}") from exc
        raise


def _connect(path: Path, uri: str) -> sqlite3.Connection:
    """Connection in autocommit mode (transactions are explicit), WAL journal, synchronous=FULL."""
    try:
        conn = sqlite3.connect(uri, uri=True, isolation_level=None, timeout=BUSY_TIMEOUT_S)
        mode = conn.execute("PRAGMA journal_mode=WAL").fetchone()[0]
        conn.execute("PRAGMA synchronous=FULL")
        conn.execute("PRAGMA foreign_keys=ON")
    except sqlite3.DatabaseError as exc:
        if not os.access(path.parent, os.W_OK):
            raise NotASession(f"{path.parent}: the folder is not writable ({exc})") from exc
        if isinstance(exc, sqlite3.OperationalError) and not path.exists():
            raise SessionStoreError(f"{path}: cannot create the session file ({why(exc, path)})") from exc
        raise NotASession(f"{path}: not a readable SQLite session file ({exc})") from exc
    if mode.lower() != "wal":
        conn.close()
        raise SessionStoreError(f"{path}: could not switch the journal to WAL (got {mode!r})")
    return conn


def _check_file(path: Path, conn: sqlite3.Connection) -> None:
    try:
        app_id = conn.execute("PRAGMA application_id").fetchone()[0]
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        if app_id != APPLICATION_ID:
            raise NotASession(f"{path}: an SQLite file but not a rig session (application_id {app_id:#x})")
        if version > LAYOUT_VERSION:
            raise NotASession(f"{path}: layout version {version} is newer than this rig reads ({LAYOUT_VERSION})")
        problems = [row[0] for row in conn.execute("PRAGMA quick_check")]
    except sqlite3.DatabaseError as exc:
        raise SessionStoreError(f"{path}: corrupt session file ({exc})") from exc
    if problems != ["ok"]:
        raise SessionStoreError(f"{path}: corrupt session file: {'; '.join(problems[:3])}")


def _remove_sqlite_files(path: Path) -> None:
    for name in (path, path.with_name(path.name + "-wal"), path.with_name(path.name + "-shm")):
        name.unlink(missing_ok=True)
