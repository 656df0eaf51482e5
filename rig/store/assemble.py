"""Building a `SessionData` from the committed segments of a session file.

Of a hold (or move) recorded more than once for the same step, only the latest attempt is used:
a hold is repeated because the first one was disturbed (a bump), and a move is re-recorded when a
resumed run drives to the orientation again. Two contiguous visits of one step would otherwise merge
into one hold in `SessionData.hold_rows`. The superseded rows stay in the file.

Segments are concatenated in the order they were committed; the store refuses a segment that starts
before the last one ended, so this is also time order.
"""

from __future__ import annotations

import sqlite3

import numpy as np

from rig.session_data import SessionData
from rig.store import arrays
from rig.store.segment import sensor_columns

DEFAULT_GRAVITY = 9.80665

# Segments not superseded by a later-committed segment of the same phase and step. Commit order, not
# the attempt number, decides: a resumed run may record a step again starting from attempt 1.
LATEST = """
FROM segment AS s
WHERE NOT EXISTS (
    SELECT 1 FROM segment AS later WHERE later.phase = s.phase AND later.step = s.step AND later.id > s.id)
"""


def assemble_session(db: sqlite3.Connection, metadata: dict, source: str) -> SessionData:
    segments = db.execute(f"SELECT id, phase, step {LATEST} ORDER BY id").fetchall()
    loaded = _load_arrays(db)
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
        gravity=float(metadata.get("gravity_mps2", DEFAULT_GRAVITY)),
        field_uT=None if metadata.get("field_uT") is None else float(metadata["field_uT"]),
        sample_rate_hz=None if metadata.get("sample_rate_hz") is None else float(metadata["sample_rate_hz"]),
        table_deg=_concat(parts, "table_deg", (2,)),
        temp_c=_concat_optional(parts, "temp_c"),
        vsupply_v=_concat_optional(parts, "vsupply_v"),
        meta=metadata,
        source=source,
    )


def _load_arrays(db: sqlite3.Connection) -> dict[int, dict[str, np.ndarray]]:
    out: dict[int, dict[str, np.ndarray]] = {}
    rows = db.execute("SELECT segment_id, name, dtype, shape, data FROM array"
                      f" WHERE segment_id IN (SELECT s.id {LATEST})")
    for seg_id, name, dtype, shape, blob in rows:
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
