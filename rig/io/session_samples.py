"""The rules of samples.csv's columns (session-csv.md), one check per rule, each on a whole column at once.

Every check stops at the first broken row with a `SessionFormatError` naming the file, line and column, and
quotes the cell as written where the number alone would mislead. They are the reader's, kept apart from it
so that `read_session` reads as the order of the checks and each rule reads as the code that enforces it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.columns import FIRST_DATA_LINE, cell_text
from rig.io.session_format import (COUNT_LIMIT, QUAT_COLUMNS, QUAT_NORM_TOL, RATE_MISMATCH, RAW_LIMITS,
                                   REQUIRED_COLUMNS, TABLE_COLUMNS)


def check_header(path: Path, header: list[str], meta: dict, free: bool) -> None:
    """The header has the required columns (only `t` without a turntable, `free`), each group of columns whole,
    and every raw column meta.json names."""
    required = ("t",) if free else REQUIRED_COLUMNS
    for name in required:
        if name not in header:
            raise SessionFormatError(path, "required column missing from the header", 1, name)
    for group in (QUAT_COLUMNS, ("phase", "step"), TABLE_COLUMNS):
        present = [c in header for c in group]
        if any(present) and not all(present):
            missing = group[present.index(False)]
            raise SessionFormatError(path, f"columns {', '.join(group)} come together; this one is missing", 1,
                                     missing)
    for sensor, names in meta["sensors"].items():
        for name in names:
            if name not in header:
                raise SessionFormatError(path, f"raw column of sensor {sensor!r} (meta.json) missing from the header",
                                         1, name)


def check_range(path: Path, name: str, values: np.ndarray, lo: float, hi: float, unit: str) -> None:
    """Finite is not enough: a 1e308 temperature passes every parser and breaks every fit after it."""
    bad = (values < lo) | (values > hi)
    if bad.any():
        i = int(np.argmax(bad))
        line = i + FIRST_DATA_LINE
        raise SessionFormatError(path, f"{cell_text(path, line, name)} {unit} is outside the plausible range "
                                 f"{lo:g} .. {hi:g} {unit}", line, name)


def integers(path: Path, name: str, values: np.ndarray) -> np.ndarray:
    """`values` as int64; a value with a fraction is an error quoting its cell."""
    bad = values != np.round(values)
    if bad.any():
        i = int(np.argmax(bad))
        line = i + FIRST_DATA_LINE
        raise SessionFormatError(path, f"{cell_text(path, line, name)!r} is not an integer", line, name)
    return values.astype(np.int64)


def check_increasing(path: Path, t: np.ndarray) -> None:
    """t increases strictly from row to row."""
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise SessionFormatError(path, f"t = {float(t[i])!r} s is not after the previous row's t = {float(t[i - 1])!r} s "
                                 "(t must increase monotonically)", i + FIRST_DATA_LINE, "t")


def check_time_unit(path: Path, t: np.ndarray, rate_hz: float) -> None:
    """t is in seconds (session-csv.md); rows `RATE_MISMATCH` times further apart or closer than meta.json's
    sample_rate_hz says are a t in another unit (a logger's milliseconds: 1000 times). Read as seconds, such a file
    calibrated the gyro 1000 times too small with exit 0 and no warning."""
    if len(t) < 3:
        return
    dt = float(np.median(np.diff(t)))
    ratio = dt * rate_hz
    if ratio > RATE_MISMATCH or ratio < 1.0 / RATE_MISMATCH:
        raise SessionFormatError(path, f"rows are {dt:.6g} s apart (median) but meta.json says sample_rate_hz "
                                 f"{rate_hz:g}: t must be in seconds (is it in ms or us?), or sample_rate_hz is "
                                 "wrong", FIRST_DATA_LINE + 1, "t")


def check_move_steps(path: Path, is_move: np.ndarray, step: np.ndarray) -> None:
    """A move row carries the step of the hold it leaves (session-csv.md)."""
    hold_rows = np.where(~is_move, np.arange(len(step)), -1)
    last_hold = np.maximum.accumulate(hold_rows)
    bad = is_move & (last_hold >= 0) & (step != step[np.maximum(last_hold, 0)])
    if bad.any():
        i = int(np.argmax(bad))
        raise SessionFormatError(path, f"move row has step {step[i]}, but the hold it leaves has step "
                                 f"{step[last_hold[i]]}", i + FIRST_DATA_LINE, "step")


def check_hold_runs(path: Path, is_hold: np.ndarray, step: np.ndarray) -> None:
    """A hold's rows are one contiguous run: a step that comes back later is an error, not a guess at which
    part to keep."""
    rows = np.flatnonzero(is_hold)
    if rows.size == 0:
        return
    starts = rows[np.concatenate([[True], (np.diff(rows) != 1) | (np.diff(step[rows]) != 0)])]
    seen: dict[int, int] = {}
    for r in starts:
        j = int(step[r])
        if j in seen:
            raise SessionFormatError(path, f"hold step {j} appears again after other rows (it began at line "
                                     f"{seen[j] + FIRST_DATA_LINE}); each hold must be one contiguous run",
                                     int(r) + FIRST_DATA_LINE, "step")
        seen[j] = int(r)


def quaternions(path: Path, cols: dict[str, np.ndarray], allow_empty: bool = False) -> np.ndarray:
    """Unit quaternions, w >= 0; a recording without a turntable may leave whole rows empty (NaN)."""
    q = np.column_stack([cols[c] for c in QUAT_COLUMNS])
    empty = np.isnan(q)
    partial = empty.any(axis=1) & ~empty.all(axis=1)
    if partial.any() or (empty.any() and not allow_empty):
        i = int(np.argmax(partial if partial.any() else empty.any(axis=1)))
        raise SessionFormatError(path, "empty cell; the quaternion needs all four components", i + FIRST_DATA_LINE,
                                 QUAT_COLUMNS[int(np.argmax(empty[i]))])
    have = ~empty.any(axis=1)
    norm = np.linalg.norm(q, axis=1)
    bad = have & (np.abs(norm - 1.0) > QUAT_NORM_TOL)
    if bad.any():
        i = int(np.argmax(bad))
        raise SessionFormatError(path, f"quaternion norm {norm[i]:.6g} is not 1 (tolerance {QUAT_NORM_TOL:g})",
                                 i + FIRST_DATA_LINE, ",".join(QUAT_COLUMNS))
    q = q / norm[:, None]
    return np.where(q[:, :1] < 0, -q, q)  # q and -q are one rotation; conventions.md stores w >= 0


def sensor_values(path: Path, cols: dict[str, np.ndarray], sensor: str, names: list[str], unit: str) -> np.ndarray:
    """One sensor's raw values, NaN on rows where it had no new sample (all three cells empty): integer counts,
    or values already in `unit` (meta.json "units")."""
    y = np.column_stack([cols[c] for c in names])
    have = ~np.isnan(y)
    partial = have.any(axis=1) & ~have.all(axis=1)
    if partial.any():
        i = int(np.argmax(partial))
        missing = names[int(np.argmin(have[i]))]
        raise SessionFormatError(path, f"sensor {sensor!r} has some but not all of its cells on this row",
                                 i + FIRST_DATA_LINE, missing)
    limit = RAW_LIMITS.get(unit, COUNT_LIMIT)
    for k, name in enumerate(names):
        values = y[:, k]
        if unit == "counts":
            bad = have[:, k] & (values != np.round(values))
            if bad.any():
                i = int(np.argmax(bad))
                line = i + FIRST_DATA_LINE
                raise SessionFormatError(path, f"{cell_text(path, line, name)!r} is not an integer count (values "
                                         f"already in physical units need \"units\": {{\"{sensor}\": ...}} in "
                                         "meta.json)", line, name)
        check_range(path, name, np.where(have[:, k], values, 0.0), -limit, limit, unit)
    return y
