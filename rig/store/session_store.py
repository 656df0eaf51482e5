"""The crash-safe, append-only store of one calibration session (`folder/session.sqlite`).

SQLite in WAL mode with `synchronous=FULL`, one transaction per hold or move. Why FULL: in WAL mode
NORMAL is already safe against a killed process, but a commit made under NORMAL can still roll back
after a power cut or kernel crash, because the WAL is synced only at checkpoints. A lab bench loses
power; FULL syncs the WAL at every commit, and with one commit per 5 s hold the fsync cost is
irrelevant (benchmarks/store_write_load.py measures it). So a crash of any kind loses at most the
hold or move in progress.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from rig.errors import RigError
from rig.session_data import SessionData
from rig.store import arrays
from rig.store.assemble import assemble_session
from rig.store.schema import APPLICATION_ID, DDL, FORMAT, LAYOUT_VERSION, SESSION_FILE
from rig.store.segment import checked_arrays, hold_stat_rows

STATUSES = ("running", "complete", "aborted", "failed")
TERMINAL_STATUSES = ("complete", "aborted", "failed")
BUSY_TIMEOUT_S = 5.0


class SessionStoreError(RigError):
    """A session folder or file cannot be used (missing, not a session, corrupt, closed); names the path."""


class SessionStore:
    """Append-only session file. Create with `SessionStore.create`, reopen with `SessionStore.open`."""

    def __init__(self, path: Path, conn: sqlite3.Connection) -> None:
        self.path = path
        self._conn: sqlite3.Connection | None = conn

    # -- opening ---------------------------------------------------------------------------------
    @classmethod
    def create(cls, folder: Path, metadata: dict) -> "SessionStore":
        """Create `folder/session.sqlite` (folder made if needed); refuses to overwrite a session."""
        folder = Path(folder)
        path = folder / SESSION_FILE
        if path.exists():
            raise SessionStoreError(f"{path}: a session already exists here; use SessionStore.open or a new folder")
        initial = {"format": FORMAT, "start_utc": _utc_now(), **metadata, "status": "running", "status_reason": ""}
        encoded = _encode_metadata(path, initial)
        folder.mkdir(parents=True, exist_ok=True)
        conn = _connect(path, uri=path.resolve().as_uri())
        store = cls(path, conn)
        with store._transaction() as db:
            db.execute(f"PRAGMA application_id={APPLICATION_ID}")
            db.execute(f"PRAGMA user_version={LAYOUT_VERSION}")
            for statement in DDL.split(";"):
                if statement.strip():
                    db.execute(statement)
            db.executemany("INSERT INTO metadata (key, value, written_utc) VALUES (?, ?, ?)", encoded)
        return store

    @classmethod
    def open(cls, folder: Path) -> "SessionStore":
        """Open an existing session for reading and appending (resume, export, report)."""
        folder = Path(folder)
        path = folder / SESSION_FILE
        if not folder.is_dir():
            raise SessionStoreError(f"{folder}: no such session folder")
        if not path.is_file():
            raise SessionStoreError(f"{folder}: not a rig session (no {SESSION_FILE})")
        conn = _connect(path, uri=path.resolve().as_uri() + "?mode=rw")
        try:
            _check_file(path, conn)
        except BaseException:
            conn.close()
            raise
        return cls(path, conn)

    # -- metadata and status ---------------------------------------------------------------------
    @property
    def metadata(self) -> dict:
        """Latest value of every metadata key."""
        rows = self._db.execute("SELECT key, value FROM metadata ORDER BY id").fetchall()
        return {key: json.loads(value) for key, value in rows}

    def update_metadata(self, **changes) -> None:
        """Record new values for keys (the old rows stay in the file)."""
        encoded = _encode_metadata(self.path, changes)
        with self._transaction() as db:
            db.executemany("INSERT INTO metadata (key, value, written_utc) VALUES (?, ?, ?)", encoded)

    def set_status(self, status: str, reason: str = "") -> None:
        """Status and reason; a terminal status also records `end_utc`. Logged as a `status` event."""
        if status not in STATUSES:
            raise ValueError(f"{self.path}: status {status!r} is not one of {', '.join(STATUSES)}")
        changes = {"status": status, "status_reason": reason}
        if status in TERMINAL_STATUSES:
            changes["end_utc"] = _utc_now()
        encoded = _encode_metadata(self.path, changes)
        with self._transaction() as db:
            db.executemany("INSERT INTO metadata (key, value, written_utc) VALUES (?, ?, ?)", encoded)
            db.execute("INSERT INTO event (t, kind, message, written_utc) VALUES (NULL, 'status', ?, ?)",
                       (f"{status}: {reason}" if reason else status, _utc_now()))

    @property
    def status(self) -> tuple[str, str]:
        meta = self.metadata
        return meta.get("status", ""), meta.get("status_reason", "")

    # -- appending -------------------------------------------------------------------------------
    def append_hold(self, step: int, *, t: np.ndarray, samples: dict[str, np.ndarray], q_ref: np.ndarray,
                    table_deg: np.ndarray, commanded_deg: tuple[float, float], measured_deg: tuple[float, float],
                    temp_c: np.ndarray | None = None, vsupply_v: np.ndarray | None = None,
                    attempt: int = 1) -> None:
        """Commit one hold (all samples, per-channel summary rows) in one transaction."""
        where = f"{self.path}: append_hold(step={step}, attempt={attempt})"
        commanded = _angle_pair(where, "commanded_deg", commanded_deg)
        measured = _angle_pair(where, "measured_deg", measured_deg)
        data = checked_arrays(where, t, samples, q_ref, table_deg, temp_c, vsupply_v)
        stats = hold_stat_rows(data, self.metadata)
        with self._transaction() as db:
            seg = self._insert_segment(db, "hold", step, attempt, data, commanded + measured)
            db.executemany("INSERT INTO hold_stat (segment_id, channel, mean, std, count) VALUES (?, ?, ?, ?, ?)",
                           [(seg, *row) for row in stats])

    def append_move(self, step: int, *, t: np.ndarray, samples: dict[str, np.ndarray], q_ref: np.ndarray,
                    table_deg: np.ndarray, temp_c: np.ndarray | None = None,
                    vsupply_v: np.ndarray | None = None) -> None:
        """Commit the full-rate stream of the move leaving orientation `step`, in one transaction."""
        where = f"{self.path}: append_move(step={step})"
        data = checked_arrays(where, t, samples, q_ref, table_deg, temp_c, vsupply_v)
        with self._transaction() as db:
            self._insert_segment(db, "move", step, 1, data, (None,) * 4)

    def log_event(self, kind: str, message: str, t: float | None = None) -> None:
        with self._transaction() as db:
            db.execute("INSERT INTO event (t, kind, message, written_utc) VALUES (?, ?, ?, ?)",
                       (None if t is None else float(t), kind, message, _utc_now()))

    # -- reading ---------------------------------------------------------------------------------
    def completed_holds(self) -> list[int]:
        """Steps with at least one committed hold, ascending."""
        rows = self._db.execute("SELECT DISTINCT step FROM segment WHERE phase = 'hold' ORDER BY step")
        return [int(step) for (step,) in rows]

    def last_time(self) -> float | None:
        """Latest committed sample time, so a resumed run can continue the session's time base."""
        (t_end,) = self._db.execute("SELECT max(t_end) FROM segment").fetchone()
        return None if t_end is None else float(t_end)

    def events(self) -> list[dict]:
        rows = self._db.execute("SELECT t, kind, message, written_utc FROM event ORDER BY id").fetchall()
        return [{"t": t, "kind": kind, "message": message, "written_utc": utc} for t, kind, message, utc in rows]

    def to_session_data(self) -> SessionData:
        """All committed rows in time order; of a hold or move recorded more than once, the last committed."""
        return assemble_session(self._db, self.metadata, source=str(self.path))

    # -- closing ---------------------------------------------------------------------------------
    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def __enter__(self) -> "SessionStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- internals -------------------------------------------------------------------------------
    @property
    def _db(self) -> sqlite3.Connection:
        if self._conn is None:
            raise SessionStoreError(f"{self.path}: the session store is closed")
        return self._conn

    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        db = self._db
        db.execute("BEGIN IMMEDIATE")
        try:
            yield db
            db.execute("COMMIT")
        except BaseException:
            if db.in_transaction:
                db.execute("ROLLBACK")
            raise

    def _insert_segment(self, db: sqlite3.Connection, phase: str, step: int, attempt: int,
                        data: dict[str, np.ndarray], angles: tuple) -> int:
        t = data["t"]
        (last_end,) = db.execute("SELECT max(t_end) FROM segment").fetchone()
        if last_end is not None and t[0] < last_end:
            raise ValueError(
                f"{self.path}: append_{phase}(step={step}): t starts at {float(t[0])!r} s, before the end of the "
                f"last committed segment ({last_end!r} s); session time must not run backwards (a resumed run "
                "continues the clock from SessionStore.last_time())")
        cursor = db.execute(
            "INSERT INTO segment (phase, step, attempt, t_start, t_end, n_rows, commanded_outer_deg,"
            " commanded_inner_deg, measured_outer_deg, measured_inner_deg, written_utc)"
            " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (phase, int(step), int(attempt), float(t[0]), float(t[-1]), int(t.size), *angles, _utc_now()))
        seg = cursor.lastrowid
        db.executemany("INSERT INTO array (segment_id, name, dtype, shape, data) VALUES (?, ?, ?, ?, ?)",
                       [(seg, name, *arrays.encode(values)) for name, values in data.items()])
        return seg


def _connect(path: Path, uri: str) -> sqlite3.Connection:
    """Connection in autocommit mode (transactions are explicit), WAL journal, synchronous=FULL."""
    try:
        conn = sqlite3.connect(uri, uri=True, isolation_level=None, timeout=BUSY_TIMEOUT_S)
        mode = conn.execute("PRAGMA journal_mode=WAL").fetchone()[0]
        conn.execute("PRAGMA synchronous=FULL")
        conn.execute("PRAGMA foreign_keys=ON")
    except sqlite3.DatabaseError as exc:
        raise SessionStoreError(f"{path}: not a readable SQLite session file ({exc})") from exc
    if mode.lower() != "wal":
        conn.close()
        raise SessionStoreError(f"{path}: could not switch the journal to WAL (got {mode!r})")
    return conn


def _check_file(path: Path, conn: sqlite3.Connection) -> None:
    try:
        app_id = conn.execute("PRAGMA application_id").fetchone()[0]
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        if app_id != APPLICATION_ID:
            raise SessionStoreError(f"{path}: an SQLite file but not a rig session (application_id {app_id:#x})")
        if version > LAYOUT_VERSION:
            raise SessionStoreError(f"{path}: layout version {version} is newer than this rig reads ({LAYOUT_VERSION})")
        problems = [row[0] for row in conn.execute("PRAGMA quick_check")]
    except sqlite3.DatabaseError as exc:
        raise SessionStoreError(f"{path}: corrupt session file ({exc})") from exc
    if problems != ["ok"]:
        raise SessionStoreError(f"{path}: corrupt session file: {'; '.join(problems[:3])}")


def _encode_metadata(path: Path, values: dict) -> list[tuple[str, str, str]]:
    now = _utc_now()
    rows = []
    for key, value in values.items():
        try:
            rows.append((key, json.dumps(value, default=_jsonable), now))
        except TypeError as exc:
            raise ValueError(f"{path}: metadata key {key!r} is not JSON-serialisable ({exc})") from exc
    return rows


def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (Path, datetime)):
        return str(value) if isinstance(value, Path) else value.isoformat()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def _angle_pair(where: str, name: str, pair) -> tuple[float, float]:
    values = tuple(float(v) for v in pair)
    if len(values) != 2:
        raise ValueError(f"{where}: {name} must be (outer_deg, inner_deg), got {pair!r}")
    return values


def _utc_now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")
