"""Read the interchange session layout `imu-session-csv/1` (docs/reference/session-csv.md).

A session folder holds `meta.json` and `samples.csv`. Reading validates every rule of the spec and
stops at the first broken one with a `SessionFormatError` naming file, line and column: a wrong
matrix calibrated from a silently mis-read file costs far more than a refused import. Checks run
vectorised over whole columns; only when one fails is the column scanned for the first bad line.
The rules of meta.json are in rig.io.session_meta, those of samples.csv's columns in rig.io.session_samples,
the layout's names and limits in rig.io.session_format; rig.io.session_writer writes a session.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.columns import FIRST_DATA_LINE, read_columns, read_header
from rig.io.session_format import (ANGLE_LIMIT_DEG, META_FILE, PHASES, QUAT_COLUMNS, SAMPLES_FILE, SUPPLY_RANGE_V,
                                   T_LIMIT_S, TABLE_COLUMNS, TEMP_RANGE_C)
from rig.io.session_meta import read_meta
from rig.io.session_samples import (check_header, check_hold_runs, check_increasing, check_move_steps, check_range,
                                    check_time_unit, integers, quaternions, sensor_values)
from rig.session_data import SessionData, no_reference


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
    q_ref = quaternions(samples, cols, allow_empty=free) if has_q else no_reference(n)

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
