"""The SQLite layout of a session file (`rig-session-sqlite/1`).

Every table is append-only: a repeated hold is a new `segment` row (its `attempt` is recorded), a
metadata change is a new `metadata` row for the same key. Readers take the latest committed row;
nothing is overwritten, so a crash can only lose the transaction in progress.

- `segment`: one row per committed hold or move (phase, step, attempt, time span, commanded and
  measured table angles of a hold). A move is committed with the hold it leads to.
- `array`: the sample arrays of a segment (`t`, `q_ref`, `table_deg`, `temp_c`, `vsupply_v`,
  `raw:<sensor>`) as BLOBs (see `arrays.py`).
- `hold_stat`: per-channel mean/std/count of each hold, so a session can be inspected with the
  `sqlite3` shell without numpy.
- `metadata`: key -> JSON value history. `event`: the session log.

Every row records when it was written (`written_utc`, as `utc_now` spells it).
"""

from __future__ import annotations

import sqlite3
from datetime import datetime, timezone

SESSION_FILE = "session.sqlite"
FORMAT = "rig-session-sqlite/1"
# PRAGMA application_id marks the file as ours ("RIGS" in ASCII); user_version is the layout version.
APPLICATION_ID = 0x52494753
LAYOUT_VERSION = 1

DDL = """
CREATE TABLE segment (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    phase TEXT NOT NULL CHECK (phase IN ('hold', 'move')),
    step INTEGER NOT NULL,
    attempt INTEGER NOT NULL DEFAULT 1,
    t_start REAL NOT NULL,
    t_end REAL NOT NULL,
    n_rows INTEGER NOT NULL,
    commanded_outer_deg REAL, commanded_inner_deg REAL,
    measured_outer_deg REAL, measured_inner_deg REAL,
    written_utc TEXT NOT NULL
);
CREATE TABLE array (
    segment_id INTEGER NOT NULL REFERENCES segment(id),
    name TEXT NOT NULL,
    dtype TEXT NOT NULL,
    shape TEXT NOT NULL,
    data BLOB NOT NULL,
    PRIMARY KEY (segment_id, name)
);
CREATE TABLE hold_stat (
    segment_id INTEGER NOT NULL REFERENCES segment(id),
    channel TEXT NOT NULL,
    mean REAL, std REAL, count INTEGER NOT NULL,
    PRIMARY KEY (segment_id, channel)
);
CREATE TABLE metadata (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    key TEXT NOT NULL,
    value TEXT NOT NULL,
    written_utc TEXT NOT NULL
);
CREATE TABLE event (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    t REAL,
    kind TEXT NOT NULL,
    message TEXT NOT NULL,
    written_utc TEXT NOT NULL
);
CREATE INDEX segment_phase_step ON segment(phase, step);
"""


def create_tables(db: sqlite3.Connection) -> None:
    """Lay out an empty database as a session file: marked as ours, this layout version, every table."""
    db.execute(f"PRAGMA application_id={APPLICATION_ID}")
    db.execute(f"PRAGMA user_version={LAYOUT_VERSION}")
    for statement in DDL.split(";"):
        if statement.strip():
            db.execute(statement)


def utc_now() -> str:
    """The current UTC time to the millisecond, ISO 8601 with a `Z`: the `written_utc` of a row."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")
