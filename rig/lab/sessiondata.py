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
from rig.store.schema import DDL


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
