"""The session's `segment`, `array` and `hold_stat` tables: writing one hold or move, and what a resumed run
asks of them (the holds done, the time to continue from).

Session time never runs backwards in the file: a segment that starts before the last committed one ended is
refused, so the order segments were committed in is also their time order.
"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np

from rig.store import arrays
from rig.store.schema import utc_now


def insert_segment(db: sqlite3.Connection, path: Path, phase: str, step: int, attempt: int,
                   data: dict[str, np.ndarray], angles: tuple) -> int:
    """Write one hold or move of the session file `path` (its `segment` row and arrays); its segment id."""
    t = data["t"]
    check_continues(f"{path}: append_{phase}(step={step})", t, last_time(db),
                    " (a resumed run continues the clock from SessionStore.last_time())")
    cursor = db.execute(
        "INSERT INTO segment (phase, step, attempt, t_start, t_end, n_rows, commanded_outer_deg,"
        " commanded_inner_deg, measured_outer_deg, measured_inner_deg, written_utc)"
        " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
        (phase, int(step), int(attempt), float(t[0]), float(t[-1]), int(t.size), *angles, utc_now()))
    seg = cursor.lastrowid
    db.executemany("INSERT INTO array (segment_id, name, dtype, shape, data) VALUES (?, ?, ?, ?, ?)",
                   [(seg, name, *arrays.encode(values)) for name, values in data.items()])
    return seg


def insert_hold_stats(db: sqlite3.Connection, segment_id: int,
                      stats: list[tuple[str, float | None, float | None, int]]) -> None:
    """The (channel, mean, std, count) rows of `segment.hold_stat_rows` for the hold `segment_id`."""
    db.executemany("INSERT INTO hold_stat (segment_id, channel, mean, std, count) VALUES (?, ?, ?, ?, ?)",
                   [(segment_id, *row) for row in stats])


def check_continues(where: str, t: np.ndarray, last_end: float | None, hint: str = "") -> None:
    """ValueError naming `where` (and ending with `hint`) if the times `t` start before `last_end`, the end of the
    last committed segment."""
    if last_end is not None and t[0] < last_end:
        raise ValueError(f"{where}: t starts at {float(t[0])!r} s, before the end of the last committed segment "
                         f"({last_end!r} s); session time must not run backwards{hint}")


def completed_holds(db: sqlite3.Connection) -> list[int]:
    """Steps with at least one committed hold, ascending."""
    rows = db.execute("SELECT DISTINCT step FROM segment WHERE phase = 'hold' ORDER BY step")
    return [int(step) for (step,) in rows]


def last_time(db: sqlite3.Connection) -> float | None:
    """Latest committed sample time, so a resumed run can continue the session's time base."""
    (t_end,) = db.execute("SELECT max(t_end) FROM segment").fetchone()
    return None if t_end is None else float(t_end)
