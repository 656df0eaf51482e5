"""Write a `SessionData` as an interchange folder (`imu-session-csv/1`, docs/reference/session-csv.md).

Kept apart from the reader: writing needs the layout's names (rig.io.session_format) but none of the reader's
checks. It refuses with a ValueError a session the reader would refuse for t not increasing, a quaternion that
is not a unit, a fraction in raw counts, an empty cell where the spec allows none or a magnetometer without
field_uT, and writes each file atomically, so a refused session leaves no half-written file behind.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from rig.io.atomic import write_text_atomic
from rig.io.session_format import FORMAT, META_FILE, QUAT_COLUMNS, QUAT_NORM_TOL, SAMPLES_FILE, TABLE_COLUMNS
from rig.session_data import SessionData

WRITE_BLOCK_ROWS = 50_000


def write_session(session: SessionData, folder: str | os.PathLike, extra_meta: dict | None = None) -> Path:
    """Write `session` as an interchange folder (created if needed); returns the folder.

    Raw counts are written as integers (values in physical units, per `meta["units"]`, as floats) and NaN as
    empty cells; a recording without a reference (all `q_ref` NaN) is written without quaternion columns, and
    one without known holds (every row `step` -1) without `phase`/`step`. Keys of `session.meta` that the
    layout does not define are kept, `extra_meta` is merged last. Rows are formatted a block at a time, so a
    long recording is never held in memory as text.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    meta = _meta_for(session, extra_meta)
    _check_writable(session)
    n = len(session.t)
    units = meta.get("units", {})
    columns: dict[str, object] = {"t": (session.t, _format_floats, False)}
    if not (np.asarray(session.step) == -1).all():
        columns["phase"] = (session.is_move, lambda v, name, allow: np.where(v, "move", "hold").tolist(), False)
        columns["step"] = (np.asarray(session.step), lambda v, name, allow: [str(int(x)) for x in v.tolist()], False)
    q = np.asarray(session.q_ref, dtype=float)
    if not np.isnan(q).all():
        for k, name in enumerate(QUAT_COLUMNS):
            columns[name] = (q[:, k], _format_floats, meta.get("reference") == "none")
    if session.table_deg is not None:
        for k, name in enumerate(TABLE_COLUMNS):
            columns[name] = (session.table_deg[:, k], _format_floats, True)
    for sensor, names in session.columns.items():
        fmt = _format_counts if units.get(sensor, "counts") == "counts" else _format_floats
        for k, name in enumerate(names):
            columns[name] = (session.raw[sensor][:, k], fmt, True)
    if session.temp_c is not None:
        columns["temp_c"] = (session.temp_c, _format_floats, True)
    if session.vsupply_v is not None:
        columns["vsupply_v"] = (session.vsupply_v, _format_floats, True)
    for name, (values, _, _) in columns.items():
        if len(values) != n:
            raise ValueError(f"session column {name!r} has {len(values)} rows, t has {n}")

    def pieces():
        yield ",".join(columns) + "\n"
        for lo in range(0, n, WRITE_BLOCK_ROWS):
            block = [fmt(values[lo:lo + WRITE_BLOCK_ROWS], name, allow) for name, (values, fmt, allow)
                     in columns.items()]
            yield "".join(",".join(row) + "\n" for row in zip(*block))

    write_text_atomic(folder / SAMPLES_FILE, pieces())
    write_text_atomic(folder / META_FILE, json.dumps(meta, indent=2, default=_json_default) + "\n")
    return folder


def _check_writable(session: SessionData) -> None:
    """Refuse to write a file that read_session would refuse."""
    bad = np.flatnonzero(np.diff(session.t) <= 0)
    if bad.size:
        raise ValueError(f"t must increase: row {int(bad[0]) + 1} t = {session.t[bad[0] + 1]!r} s")
    q = np.asarray(session.q_ref, dtype=float)
    if session.meta.get("reference") == "none":
        q = q[~np.isnan(q).any(axis=1)]
    norm = np.linalg.norm(q, axis=1)
    bad = np.flatnonzero(~(np.abs(norm - 1.0) <= QUAT_NORM_TOL))
    if bad.size:
        raise ValueError(f"q_ref row {int(bad[0])} has norm {norm[bad[0]]!r}, not 1")


def _json_default(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(f"meta value {x!r} of type {type(x).__name__} is not JSON serialisable")


def _meta_for(session: SessionData, extra_meta: dict | None) -> dict:
    """session.meta, then extra_meta, then what the arrays themselves say (which always wins)."""
    meta = {"format": FORMAT, **session.meta, **(extra_meta or {})}
    meta.update({"format": FORMAT, "gravity_mps2": float(session.gravity),
                 "sensors": {s: list(c) for s, c in session.columns.items()}})
    if session.field_uT is not None:
        meta["field_uT"] = float(session.field_uT)
    if session.sample_rate_hz is not None:
        meta["sample_rate_hz"] = float(session.sample_rate_hz)
    if "mag" in session.raw and meta.get("field_uT") is None and meta.get("reference", "table") != "none":
        raise ValueError("a session with a magnetometer on a table needs field_uT (session-csv.md)")
    return meta


def _format_floats(values: np.ndarray, name: str, allow_nan: bool = False) -> list[str]:
    """Shortest round-trip text of each value (Python's repr); NaN as an empty cell where allowed."""
    values = np.asarray(values, dtype=float)
    finite = np.isfinite(values)
    if not allow_nan and not finite.all():
        raise ValueError(f"column {name!r}: non-finite value at row {int(np.argmin(finite))}")
    return [repr(v) if ok else "" for v, ok in zip(values.tolist(), finite.tolist())]


def _format_counts(values: np.ndarray, name: str, allow_nan: bool = True) -> list[str]:
    values = np.asarray(values, dtype=float)
    have = ~np.isnan(values)
    bad = have & ((values != np.round(values)) | ~np.isfinite(values))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"column {name!r}: raw counts must be integers, row {i} holds {values[i]!r}")
    return [str(int(v)) if ok else "" for v, ok in zip(values.tolist(), have.tolist())]
