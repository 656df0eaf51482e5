"""Building a `SessionData` from the committed segments of a session file.

Of a move recorded more than once for the same step, only the latest is used: a resumed run records
again the move an interruption cut off (or left without the hold that ends it). Of a hold recorded more
than once in one run, only the latest attempt is used: a hold is repeated because the first one was
disturbed (a bump). A resumed run starts by holding again at the last orientation recorded before the
interruption; that visit is kept beside the first one, and as the two are contiguous rows of one step,
`SessionData.hold_rows` sees one hold whose first rows end the move before the interruption and whose last
rows start the move after it. So no move spans the clock gap of a resume. A step redone within a run (a chip
reset to its power-on registers spoiled it, `SessionStore.redo`) starts the same way, from the previous hold
held again. The superseded rows stay in the file.

Runs are told apart by the `resume` events: each records the session time its run starts at.

Segments are concatenated in the order they were committed; the store refuses a segment that starts
before the last one ended, so this is also time order.
"""

from __future__ import annotations

import sqlite3

import numpy as np

from rig.units import STANDARD_GRAVITY
from rig.session_data import SessionData
from rig.store import arrays
from rig.store.segment import sensor_columns


RESUME_EVENT = "resume"
REDO_EVENT = "redo"


def resume_times(db: sqlite3.Connection) -> list[float]:
    """Session times at which resumed runs started, ascending."""
    rows = db.execute("SELECT t FROM event WHERE kind = ? AND t IS NOT NULL ORDER BY t", (RESUME_EVENT,))
    return [float(t) for (t,) in rows]


def run_starts(db: sqlite3.Connection) -> list[float]:
    """Session times at which a run (a resume) or a redone step (`SessionStore.redo`) started, ascending."""
    rows = db.execute("SELECT t FROM event WHERE kind IN (?, ?) AND t IS NOT NULL ORDER BY t",
                      (RESUME_EVENT, REDO_EVENT))
    return [float(t) for (t,) in rows]


def used_segments(db: sqlite3.Connection) -> list[tuple[int, str, int]]:
    """(id, phase, step) of the segments a session is built from, in commit order (see the module doc).

    Commit order, not the attempt number, decides what is latest: a resumed run numbers its attempts from 1.
    A redone step (a chip reset spoiled it) is held again like a resumed run, and kept the same way.
    """
    starts = run_starts(db)
    rows = db.execute("SELECT id, phase, step, t_start FROM segment ORDER BY id").fetchall()
    run_of = {seg: sum(t >= s for s in starts) for seg, _, _, t in rows}
    latest: dict[tuple, int] = {}
    for seg, phase, step, _ in rows:
        latest[(phase, step) if phase == "move" else (phase, step, run_of[seg])] = seg
    keep = set(latest.values())
    return [(seg, phase, step) for seg, phase, step, _ in rows if seg in keep]


def assemble_session(db: sqlite3.Connection, metadata: dict, source: str) -> SessionData:
    segments = used_segments(db)
    loaded = _load_arrays(db, [seg for seg, _, _ in segments])
    parts = [loaded.get(seg_id, {}) for seg_id, _, _ in segments]
    sizes = [part["t"].size for part in parts]
    sensors = list(dict.fromkeys(name[4:] for part in parts for name in part if name.startswith("raw:")))
    raw = {s: _concat(parts, f"raw:{s}", (3,)) for s in sensors}
    return SessionData(
        t=_concat(parts, "t", ()),
        is_move=np.repeat([phase == "move" for _, phase, _ in segments], sizes).astype(bool),
        step=np.repeat([step for _, _, step in segments], sizes).astype(int),
        q_ref=_concat(parts, "q_ref", (4,)),
        raw=raw,
        columns={s: sensor_columns(s, metadata) for s in sensors},
        gravity=float(metadata.get("gravity_mps2", STANDARD_GRAVITY)),
        field_uT=None if metadata.get("field_uT") is None else float(metadata["field_uT"]),
        sample_rate_hz=None if metadata.get("sample_rate_hz") is None else float(metadata["sample_rate_hz"]),
        table_deg=_concat(parts, "table_deg", (2,)),
        temp_c=_concat_optional(parts, "temp_c"),
        vsupply_v=_concat_optional(parts, "vsupply_v"),
        meta=metadata,
        source=source,
    )


def _load_arrays(db: sqlite3.Connection, segments: list[int]) -> dict[int, dict[str, np.ndarray]]:
    out: dict[int, dict[str, np.ndarray]] = {}
    wanted = set(segments)
    rows = db.execute("SELECT segment_id, name, dtype, shape, data FROM array")
    for seg_id, name, dtype, shape, blob in rows:
        if seg_id not in wanted:
            continue
        try:
            out.setdefault(seg_id, {})[name] = arrays.decode(dtype, shape, blob)
        except ValueError as exc:
            raise ValueError(f"segment {seg_id}, array {name!r}: {exc}") from exc
    return out


def _concat(parts: list[dict], name: str, tail: tuple[int, ...]) -> np.ndarray:
    """Concatenate one array over the segments; NaN rows where a segment lacks it (a sensor absent)."""
    blocks = [part.get(name, np.full((part["t"].size, *tail), np.nan)) for part in parts]
    return np.concatenate(blocks) if blocks else np.empty((0, *tail))


def _concat_optional(parts: list[dict], name: str) -> np.ndarray | None:
    return _concat(parts, name, ()) if any(name in part for part in parts) else None
