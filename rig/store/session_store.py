"""The crash-safe, append-only store of one calibration session (`folder/session.sqlite`).

One transaction per hold, with the move that led to it: a crash of any kind loses at most the hold in progress
and the move into it (`sqlite_file` says why). A full disk must not leave a session marked "running": a status
that cannot be written otherwise is written in the space the store keeps in hand (`space_reserve`).
"""

from __future__ import annotations

import sqlite3
from contextlib import AbstractContextManager
from pathlib import Path

import numpy as np

from rig.session_data import SessionData
from rig.store.assemble import REDO_EVENT, RESUME_EVENT, assemble_session, resume_times
from rig.store.event_table import insert_event, read_events
from rig.store.metadata_table import encode_metadata, insert_metadata, latest_metadata
from rig.store.schema import FORMAT, SESSION_FILE, utc_now
from rig.store.segment import angle_pair, checked_arrays, hold_stat_rows
from rig.store.segment_table import (check_continues, completed_holds, insert_hold_stats, insert_segment,
                                     last_time)
from rig.store.space_reserve import SpaceReserve
from rig.store.sqlite_file import (NotASession, SessionStoreError, create_session_file, open_session_file,
                                   transaction)
from rig.store.status import status_changes


class SessionStore:
    """Append-only session file. Create with `SessionStore.create`, reopen with `SessionStore.open`."""

    def __init__(self, path: Path, conn: sqlite3.Connection) -> None:
        self.path = path
        self._conn: sqlite3.Connection | None = conn
        self._pending_move: tuple[int, dict[str, np.ndarray]] | None = None
        self._reserve = SpaceReserve(path.parent)

    # -- opening ---------------------------------------------------------------------------------
    @classmethod
    def create(cls, folder: Path, metadata: dict) -> "SessionStore":
        """Create `folder/session.sqlite` (folder made if needed), whole or not at all; refuses to overwrite a
        session."""
        folder = Path(folder)
        path = folder / SESSION_FILE
        if path.exists():
            raise NotASession(f"{folder}: a session already exists here (finish it with `rig resume {folder}`, "
                              "or choose another folder)")
        initial = {"format": FORMAT, "start_utc": utc_now(), **metadata, "status": "running", "status_reason": ""}
        store = cls(path, create_session_file(path, encode_metadata(path, initial)))
        store.keep_reserve()
        return store

    @classmethod
    def open(cls, folder: Path) -> "SessionStore":
        """Open an existing session for reading and appending (resume, export, report)."""
        folder = Path(folder)
        path = folder / SESSION_FILE
        if not folder.is_dir():
            raise NotASession(f"{folder}: no such session folder")
        if not path.is_file():
            raise NotASession(f"{folder}: not a rig session (no {SESSION_FILE})")
        return cls(path, open_session_file(path))

    # -- metadata and status ---------------------------------------------------------------------
    @property
    def metadata(self) -> dict:
        """Latest value of every metadata key."""
        return latest_metadata(self._db)

    def update_metadata(self, **changes) -> None:
        """Record new values for keys (the old rows stay in the file)."""
        encoded = encode_metadata(self.path, changes)
        with self._transaction() as db:
            insert_metadata(db, encoded)

    def set_status(self, status: str, reason: str = "", **extra) -> None:
        """Status and reason (and `extra` metadata keys, in the same transaction); a terminal status also
        records `end_utc`. Logged as a `status` event. If the disk is full, the reserve is given up to
        write it."""
        encoded = encode_metadata(self.path, status_changes(self.path, status, reason, extra))

        def write() -> None:
            with self._transaction() as db:
                insert_metadata(db, encoded)
                insert_event(db, None, "status", f"{status}: {reason}" if reason else status)
        try:
            write()
        except SessionStoreError:
            if not self.release_reserve():
                raise
            write()

    def keep_reserve(self) -> None:
        """(Re)write the reserve file, so a status can still be written when the disk fills up."""
        self._reserve.keep()

    def release_reserve(self) -> bool:
        """Give the reserve's space back; False if there was none."""
        return self._reserve.release()

    def mark_resume(self, t0: float, after_t: float | None, reason: str) -> None:
        """Record that a resumed run starts at session time `t0` (the last run ended at `after_t`): a clock gap
        no move may span. Kept as a `resume` event (runs are told apart by them) and in `resumes` metadata."""
        mark = {"t_s": float(t0), "after_s": None if after_t is None else float(after_t), "utc": utc_now(),
                "reason": reason}
        encoded = encode_metadata(self.path, {"resumes": [*self.metadata.get("resumes", []), mark]})
        with self._transaction() as db:
            insert_metadata(db, encoded)
            insert_event(db, float(t0), RESUME_EVENT, f"resumed at session time {t0:.3f} s"
                         + (f" after {after_t:.3f} s" if after_t is not None else "") + f": {reason}")

    def resume_times(self) -> list[float]:
        return resume_times(self._db)

    @property
    def status(self) -> tuple[str, str]:
        meta = self.metadata
        return meta.get("status", ""), meta.get("status_reason", "")

    # -- appending -------------------------------------------------------------------------------
    def append_hold(self, step: int, *, t: np.ndarray, samples: dict[str, np.ndarray], q_ref: np.ndarray,
                    table_deg: np.ndarray, commanded_deg: tuple[float, float], measured_deg: tuple[float, float],
                    temp_c: np.ndarray | None = None, vsupply_v: np.ndarray | None = None,
                    attempt: int = 1) -> None:
        """Commit one hold (all samples, per-channel summary rows), with the move that led to it, in one
        transaction."""
        where = f"{self.path}: append_hold(step={step}, attempt={attempt})"
        commanded = angle_pair(where, "commanded_deg", commanded_deg)
        measured = angle_pair(where, "measured_deg", measured_deg)
        data = checked_arrays(where, t, samples, q_ref, table_deg, temp_c, vsupply_v)
        stats = hold_stat_rows(data, self.metadata)
        move, self._pending_move = self._pending_move, None
        with self._transaction() as db:
            if move is not None:
                insert_segment(db, self.path, "move", move[0], 1, move[1], (None,) * 4)
            seg = insert_segment(db, self.path, "hold", step, attempt, data, commanded + measured)
            insert_hold_stats(db, seg, stats)

    def append_move(self, step: int, *, t: np.ndarray, samples: dict[str, np.ndarray], q_ref: np.ndarray,
                    table_deg: np.ndarray, temp_c: np.ndarray | None = None,
                    vsupply_v: np.ndarray | None = None) -> None:
        """The full-rate stream of the move leaving orientation `step`, checked now and committed with the hold
        it leads to (`append_hold`), in the same transaction.

        A move is of use only with the hold that ends it; committed alone, an interruption before that hold
        would leave it in the file, and the resumed run, which records the move again, would store it twice.
        """
        where = f"{self.path}: append_move(step={step})"
        data = checked_arrays(where, t, samples, q_ref, table_deg, temp_c, vsupply_v)
        check_continues(where, data["t"], self.last_time())
        self._pending_move = (int(step), data)

    def redo(self, t: float, reason: str) -> None:
        """The procedure redoes a step from session time `t`, holding again at the last stored hold: the move
        appended last (not committed with a hold) is forgotten, and the visit from `t` is kept beside the first
        one like a resumed run's (see `rig.store.assemble`). No clock gap: moves recorded from `t` are whole."""
        self._pending_move = None
        with self._transaction() as db:
            insert_event(db, float(t), REDO_EVENT, reason)

    def log_event(self, kind: str, message: str, t: float | None = None) -> None:
        with self._transaction() as db:
            insert_event(db, t, kind, message)

    # -- reading ---------------------------------------------------------------------------------
    def completed_holds(self) -> list[int]:
        """Steps with at least one committed hold, ascending."""
        return completed_holds(self._db)

    def last_time(self) -> float | None:
        """Latest committed sample time, so a resumed run can continue the session's time base."""
        return last_time(self._db)

    def events(self) -> list[dict]:
        return read_events(self._db)

    def to_session_data(self) -> SessionData:
        """All committed rows in time order; of a hold or move recorded more than once, the last committed."""
        return assemble_session(self._db, self.metadata, source=str(self.path))

    # -- closing ---------------------------------------------------------------------------------
    def close(self) -> None:
        """Close the file; a move not yet followed by its hold is not written."""
        self._pending_move = None
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

    def _transaction(self) -> AbstractContextManager[sqlite3.Connection]:
        return transaction(self._db, self.path)
