"""The session's `event` table: its log of status changes, resumes, redone steps and the procedure's notes.

An event may carry the session time it happened at (`t`, seconds) or none (a status change); every row carries
the UTC time it was written.
"""

from __future__ import annotations

import sqlite3

from rig.store.schema import utc_now


def insert_event(db: sqlite3.Connection, t: float | None, kind: str, message: str) -> None:
    db.execute("INSERT INTO event (t, kind, message, written_utc) VALUES (?, ?, ?, ?)",
               (None if t is None else float(t), kind, message, utc_now()))


def read_events(db: sqlite3.Connection) -> list[dict]:
    """Every event in the order written: t, kind, message, written_utc."""
    rows = db.execute("SELECT t, kind, message, written_utc FROM event ORDER BY id").fetchall()
    return [{"t": t, "kind": kind, "message": message, "written_utc": utc} for t, kind, message, utc in rows]
