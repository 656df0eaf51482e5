"""Read and write the interchange session layout `imu-session-csv/1` (shared/spec/session-csv.md).

A session folder holds `meta.json` and `samples.csv`. Reading validates every rule of the spec and
stops at the first broken one with a `SessionFormatError` naming file, line and column: a wrong
matrix calibrated from a silently mis-read file costs far more than a refused import. Checks run
vectorised over whole columns; only when one fails is the column scanned for the first bad line.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.atomic import write_text_atomic
from rig.io.columns import FIRST_DATA_LINE, read_columns, read_header
from rig.io.session_format import (ANGLE_LIMIT_DEG, FORMAT, META_FILE, PHASES, QUAT_COLUMNS, QUAT_NORM_TOL,
                                   SAMPLES_FILE, SUPPLY_RANGE_V, T_LIMIT_S, TABLE_COLUMNS, TEMP_RANGE_C)
from rig.io.session_meta import read_meta
from rig.io.session_samples import (check_header, check_hold_runs, check_increasing, check_move_steps, check_range,
                                    check_time_unit, integers, quaternions, sensor_values)
from rig.session_data import SessionData

WRITE_BLOCK_ROWS = 50_000


def read_session(folder: str | os.PathLike) -> SessionData:
    """Load and validate one session folder; the result's `meta` keeps every key of meta.json.

    A recording without a turntable (`"reference": "none"`, session-csv.md) may lack the quaternion columns
    (its `q_ref` is then NaN) and `phase`/`step` (then no row belongs to a known hold: `is_move` is true and
    `step` is -1 on every row, and static intervals are found from the data or from `segments`).
    """
    folder = Path(folder)
    meta = read_meta(folder / META_FILE)
    samples = folder / SAMPLES_FILE
    header = read_header(samples)
    free = meta.get("reference", "table") == "none"
    check_header(samples, header, meta, free)
    has_q = QUAT_COLUMNS[0] in header
    has_phase = "phase" in header
    raw_names = [c for names in meta["sensors"].values() for c in names]
    optional = [c for c in (*TABLE_COLUMNS, "temp_c", "vsupply_v") if c in header]
    numeric = ["t", *(["step"] if has_phase else []), *(QUAT_COLUMNS if has_q else ()), *raw_names, *optional]
    required = ("t", *(["step"] if has_phase else []), *(QUAT_COLUMNS if has_q and not free else ()))
    counts = [c for name, names in meta["sensors"].items() if meta.get("units", {}).get(name, "counts") == "counts"
              for c in names]
    cols = read_columns(samples, header, numeric, ["phase"] if has_phase else [], required=required,
                        integers=(*(["step"] if has_phase else []), *counts))
    n = len(cols["t"])

    t = cols["t"]
    check_increasing(samples, t)
    check_range(samples, "t", t, -T_LIMIT_S, T_LIMIT_S, "s")
    if meta.get("sample_rate_hz") is not None:
        check_time_unit(samples, t, float(meta["sample_rate_hz"]))
    if has_phase:
        phase = cols["phase"]
        bad = ~np.isin(phase, PHASES)
        if bad.any():
            i = int(np.argmax(bad))
            raise SessionFormatError(samples, f"phase {str(phase[i])!r} is not 'hold' or 'move'", i + FIRST_DATA_LINE,
                                     "phase")
        step = integers(samples, "step", cols["step"])
        check_move_steps(samples, phase == "move", step)
        check_hold_runs(samples, phase == "hold", step)
        is_move = phase == "move"
    else:
        step, is_move = np.full(n, -1, dtype=np.int64), np.ones(n, dtype=bool)
    q_ref = quaternions(samples, cols, allow_empty=free) if has_q else np.full((n, 4), np.nan)

    units = meta.get("units", {})
    raw = {name: sensor_values(samples, cols, name, names, units.get(name, "counts"))
           for name, names in meta["sensors"].items()}
    table_deg = None
    if TABLE_COLUMNS[0] in header:
        table_deg = np.column_stack([cols[c] for c in TABLE_COLUMNS])
        for c in TABLE_COLUMNS:
            check_range(samples, c, cols[c], -ANGLE_LIMIT_DEG, ANGLE_LIMIT_DEG, "deg")
    temp_c = cols.get("temp_c")
    if temp_c is not None:
        check_range(samples, "temp_c", temp_c, *TEMP_RANGE_C, "degC")
    vsupply_v = cols.get("vsupply_v")
    if vsupply_v is not None:
        check_range(samples, "vsupply_v", vsupply_v, *SUPPLY_RANGE_V, "V")

    return SessionData(
        t=t, is_move=is_move, step=step, q_ref=q_ref, raw=raw,
        columns={name: list(names) for name, names in meta["sensors"].items()},
        gravity=float(meta["gravity_mps2"]),
        field_uT=float(meta["field_uT"]) if meta.get("field_uT") is not None else None,
        sample_rate_hz=float(meta["sample_rate_hz"]) if meta.get("sample_rate_hz") is not None else None,
        table_deg=table_deg, temp_c=temp_c, vsupply_v=vsupply_v, meta=meta, source=str(folder))


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
    if "mag" in session.raw and meta.get("field_uT") is None:
        raise ValueError("a session with a magnetometer needs field_uT (session-csv.md)")
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
