"""A stored session as the analysis reads it (`SessionData`), built by the session store's own assembly.

Rows from the central store are put back into an in-memory SQLite file of the session layout and handed to
`rig.store.assemble.assemble_session`, the one place that knows which repeated holds and moves count, so a
session analysed from the central store is the same as one analysed from its folder.
"""

from __future__ import annotations

import json
import sqlite3

from rig.session_data import SessionData, with_configuration_facts
from rig.store.assemble import assemble_session
from rig.store.schema import DDL, create_tables


def loads(text):
    if not isinstance(text, str):
        return text
    try:
        return json.loads(text)
    except ValueError:
        return text


def from_sqlite(conn: sqlite3.Connection, meta: dict, source: str) -> SessionData:
    return with_configuration_facts(assemble_session(conn, meta, source=source))


def from_rows(segments: list[tuple], arrays: list[tuple], events: list[tuple], meta: dict, source: str) -> SessionData:
    """segments: (seq, phase, step, attempt, t_start, t_end, n_rows, written_utc); arrays: (seq, name, dtype,
    shape, data); events: (seq, t, kind, message, written_utc)."""
    db = sqlite3.connect(":memory:")
    try:
        for statement in DDL.split(";"):
            if statement.strip():
                db.execute(statement)
        db.executemany("INSERT INTO segment (id, phase, step, attempt, t_start, t_end, n_rows, written_utc) "
                       "VALUES (?, ?, ?, ?, ?, ?, ?, ?)", [(*r[:7], str(r[7])) for r in segments])
        db.executemany("INSERT INTO array (segment_id, name, dtype, shape, data) VALUES (?, ?, ?, ?, ?)",
                       [(seq, name, dtype, shape, bytes(data)) for seq, name, dtype, shape, data in arrays])
        db.executemany("INSERT INTO event (id, t, kind, message, written_utc) VALUES (?, ?, ?, ?, ?)",
                       [(*r[:4], str(r[4])) for r in events])
        return from_sqlite(db, meta, source)
    finally:
        db.close()


def group_hold_means(rows: list[tuple]) -> list[dict]:
    """(seq, step, attempt, written_utc, channel, mean) rows -> one dict per hold, channels' means inside."""
    holds: dict[int, dict] = {}
    for seq, step, attempt, written, channel, mean in rows:
        hold = holds.setdefault(seq, {"seq": seq, "step": step, "attempt": attempt, "written_utc": written,
                                      "means": {}})
        if channel is not None:
            hold["means"][channel] = mean
    return list(holds.values())


def session_file(metadata: list[tuple], segments: list[tuple], arrays: list[tuple], stats: list[tuple],
                 events: list[tuple]) -> bytes:
    """A session file (`rig-session-sqlite/1`, what the rig recorded) rebuilt from the rows of a store, as bytes:
    metadata (seq, key, value, written_utc), segments (seq, phase, step, attempt, t_start, t_end, n_rows,
    commanded outer, inner, measured outer, inner, written_utc), arrays (seq, name, dtype, shape, data), hold
    statistics (seq, channel, mean, std, count) and events (seq, t, kind, message, written_utc). Every row keeps
    its id, so the copy is the same session (`rig.lab.local.LocalSession.key`) and reads as the folder did."""
    db = sqlite3.connect(":memory:")
    try:
        create_tables(db)
        db.executemany("INSERT INTO metadata (id, key, value, written_utc) VALUES (?, ?, ?, ?)", metadata)
        db.executemany("INSERT INTO segment (id, phase, step, attempt, t_start, t_end, n_rows, commanded_outer_deg, "
                       "commanded_inner_deg, measured_outer_deg, measured_inner_deg, written_utc) VALUES "
                       "(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", segments)
        db.executemany("INSERT INTO array (segment_id, name, dtype, shape, data) VALUES (?, ?, ?, ?, ?)",
                       [(seq, name, dtype, shape, bytes(data)) for seq, name, dtype, shape, data in arrays])
        db.executemany("INSERT INTO hold_stat (segment_id, channel, mean, std, count) VALUES (?, ?, ?, ?, ?)", stats)
        db.executemany("INSERT INTO event (id, t, kind, message, written_utc) VALUES (?, ?, ?, ?, ?)", events)
        db.commit()
        return db.serialize()
    finally:
        db.close()


def copy_of(conn: sqlite3.Connection) -> bytes:
    """The session file behind `conn` as bytes: a consistent snapshot (SQLite's backup) of every committed row,
    the ones still in its write-ahead log included."""
    db = sqlite3.connect(":memory:")
    try:
        conn.backup(db)
        return db.serialize()
    finally:
        db.close()
