"""Read and write the interchange session layout `imu-session-csv/1` (shared/spec/session-csv.md).

A session folder holds `meta.json` and `samples.csv`. Reading validates every rule of the spec and
stops at the first broken one with a `SessionFormatError` naming file, line and column: a wrong
matrix calibrated from a silently mis-read file costs far more than a refused import. Checks run
vectorised over whole columns; only when one fails is the column scanned for the first bad line.
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.atomic import write_text_atomic
from rig.session_data import SENSOR_UNITS, SessionData

FORMAT = "imu-session-csv/1"
META_FILE = "meta.json"
SAMPLES_FILE = "samples.csv"
QUAT_COLUMNS = ("qw", "qx", "qy", "qz")
REQUIRED_COLUMNS = ("t", "phase", "step", *QUAT_COLUMNS)
TABLE_COLUMNS = ("table_outer_deg", "table_inner_deg")
PHASES = ("hold", "move")
# A quaternion written with 6 significant digits is within ~1e-6 of unit norm; 1e-3 lets
# tracker output through and still catches a swapped or missing component.
QUAT_NORM_TOL = 1e-3
FIRST_DATA_LINE = 2


def read_session(folder: str | os.PathLike) -> SessionData:
    """Load and validate one session folder; the result's `meta` keeps every key of meta.json."""
    folder = Path(folder)
    meta = read_meta(folder / META_FILE)
    samples = folder / SAMPLES_FILE
    header, cells = _read_cells(samples)
    _check_header(samples, header, meta)
    col = _ColumnParser(samples, cells)

    t = col.floats("t")
    _check_increasing(samples, t)
    phase = col.text("phase")
    bad = ~np.isin(phase, PHASES)
    if bad.any():
        i = int(np.argmax(bad))
        raise SessionFormatError(samples, f"phase {str(phase[i])!r} is not 'hold' or 'move'", i + FIRST_DATA_LINE,
                                 "phase")
    step = col.integers("step")
    _check_move_steps(samples, phase == "move", step)
    _check_hold_runs(samples, phase == "hold", step)
    q_ref = _quaternions(samples, col)

    raw = {name: _sensor_counts(samples, col, name, names) for name, names in meta["sensors"].items()}
    table_deg = None
    if TABLE_COLUMNS[0] in cells:
        table_deg = np.column_stack([col.floats(c, allow_empty=True) for c in TABLE_COLUMNS])
    temp_c = col.floats("temp_c", allow_empty=True) if "temp_c" in cells else None
    vsupply_v = col.floats("vsupply_v", allow_empty=True) if "vsupply_v" in cells else None

    return SessionData(
        t=t, is_move=phase == "move", step=step, q_ref=q_ref, raw=raw,
        columns={name: list(names) for name, names in meta["sensors"].items()},
        gravity=float(meta["gravity_mps2"]),
        field_uT=float(meta["field_uT"]) if meta.get("field_uT") is not None else None,
        sample_rate_hz=float(meta["sample_rate_hz"]) if meta.get("sample_rate_hz") is not None else None,
        table_deg=table_deg, temp_c=temp_c, vsupply_v=vsupply_v, meta=meta, source=str(folder))


def read_meta(path: Path) -> dict:
    """Parse and validate meta.json; errors name the line of the offending key."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SessionFormatError(path, "missing: a session folder holds meta.json and samples.csv") from None
    try:
        meta = json.loads(text)
    except json.JSONDecodeError as e:
        raise SessionFormatError(path, f"not valid JSON: {e.msg} (character {e.colno})", e.lineno) from None
    if not isinstance(meta, dict):
        raise SessionFormatError(path, "must hold a JSON object", 1)

    def fail(key: str, message: str, where: str | None = None):
        raise SessionFormatError(path, message, _line_of_key(text, where or key.split(".")[-1]), key)

    if meta.get("format") != FORMAT:
        fail("format", f"format must be {FORMAT!r}, got {meta.get('format')!r}")
    if "gravity_mps2" not in meta:
        fail("gravity_mps2", "required key missing (local gravity magnitude, m/s^2)", "format")
    _check_positive(meta["gravity_mps2"], "gravity_mps2", fail)
    sensors = meta.get("sensors")
    if not isinstance(sensors, dict) or not sensors:
        fail("sensors", "required: an object mapping accel/gyro/mag to their three raw columns", "format")
    claimed: set[str] = set()
    for name, names in sensors.items():
        if name not in SENSOR_UNITS:
            fail(f"sensors.{name}", f"unknown sensor {name!r}; expected one of {sorted(SENSOR_UNITS)}")
        if (not isinstance(names, list) or len(names) != 3 or not all(isinstance(c, str) and c for c in names)
                or len(set(names)) != 3):
            fail(f"sensors.{name}", "must list three distinct raw column names in sensor-axis order")
        clash = (claimed | set(REQUIRED_COLUMNS) | set(TABLE_COLUMNS) | {"temp_c", "vsupply_v"}) & set(names)
        if clash:
            fail(f"sensors.{name}", f"column {sorted(clash)[0]!r} is already used by another column or sensor")
        claimed |= set(names)
    if "mag" in sensors:
        if meta.get("field_uT") is None:
            fail("field_uT", "required when a magnetometer is present (local field magnitude, uT)", "mag")
        _check_positive(meta["field_uT"], "field_uT", fail)
    elif meta.get("field_uT") is not None:
        _check_positive(meta["field_uT"], "field_uT", fail)
    if meta.get("sample_rate_hz") is not None:
        _check_positive(meta["sample_rate_hz"], "sample_rate_hz", fail)
    table = meta.get("table")
    if table is not None:
        if not isinstance(table, dict):
            fail("table", "must be an object with outer_axis_world and inner_axis_fixture")
        for key in ("outer_axis_world", "inner_axis_fixture"):
            v = table.get(key)
            if v is not None and not (isinstance(v, list) and len(v) == 3 and all(_is_number(x) for x in v)
                                      and any(x != 0 for x in v)):
                fail(f"table.{key}", "must be a non-zero 3-vector")
    return meta


def _check_positive(value, key: str, fail) -> None:
    if not (_is_number(value) and math.isfinite(value) and value > 0):
        fail(key, f"must be a positive number, got {value!r}")


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _line_of_key(text: str, key: str) -> int | None:
    needle = f'"{key}"'
    for i, line in enumerate(text.splitlines(), 1):
        if needle in line:
            return i
    return None


def _read_cells(path: Path) -> tuple[list[str], dict[str, tuple[str, ...]]]:
    """Header names and, per column, the cell strings of every data row."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise SessionFormatError(path, "missing: a session folder holds meta.json and samples.csv") from None
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise SessionFormatError(path, "empty file: a header row is required", 1)
    header = [h.strip() for h in next(csv.reader(lines[:1]))]
    seen: set[str] = set()
    for name in header:
        if not name:
            raise SessionFormatError(path, "empty column name in the header", 1)
        if name in seen:
            raise SessionFormatError(path, "column named twice in the header", 1, name)
        seen.add(name)
    rows = list(csv.reader(lines[1:]))
    if not rows:
        raise SessionFormatError(path, "no data rows after the header", 2)
    widths = np.fromiter(map(len, rows), dtype=np.int64, count=len(rows))
    bad = np.flatnonzero(widths != len(header))
    if bad.size:
        i = int(bad[0])
        column = header[widths[i]] if widths[i] < len(header) else None
        raise SessionFormatError(path, f"row has {widths[i]} cells, the header has {len(header)}",
                                 i + FIRST_DATA_LINE, column)
    return header, dict(zip(header, zip(*rows)))


def _check_header(path: Path, header: list[str], meta: dict) -> None:
    for name in REQUIRED_COLUMNS:
        if name not in header:
            raise SessionFormatError(path, "required column missing from the header", 1, name)
    present = [c in header for c in TABLE_COLUMNS]
    if any(present) and not all(present):
        missing = TABLE_COLUMNS[present.index(False)]
        raise SessionFormatError(path, "table angle columns come as a pair; this one is missing", 1, missing)
    for sensor, names in meta["sensors"].items():
        for name in names:
            if name not in header:
                raise SessionFormatError(path, f"raw column of sensor {sensor!r} (meta.json) missing from the header",
                                         1, name)


class _ColumnParser:
    """Typed, validated views of the cell strings of one samples.csv."""

    def __init__(self, path: Path, cells: dict[str, tuple[str, ...]]) -> None:
        self.path, self.cells = path, cells

    def text(self, name: str) -> np.ndarray:
        return np.asarray([c.strip() for c in self.cells[name]])

    def floats(self, name: str, allow_empty: bool = False) -> np.ndarray:
        values, rows, n = self._nonempty(name, allow_empty)
        out = np.full(n, np.nan)
        out[rows] = self._convert(name, values, rows, float, "is not a number")
        bad = ~np.isfinite(out[rows])
        if bad.any():
            i = int(rows[np.argmax(bad)])
            raise SessionFormatError(self.path, f"{self.cells[name][i]!r} is not a finite number (leave the cell "
                                     "empty for 'no sample')", i + FIRST_DATA_LINE, name)
        return out

    def integers(self, name: str, allow_empty: bool = False) -> np.ndarray:
        """int64 values; with allow_empty, floats with NaN in the empty cells."""
        values, rows, n = self._nonempty(name, allow_empty)
        vals = self._convert(name, values, rows, np.int64, "is not an integer")
        if not allow_empty:
            return vals
        out = np.full(n, np.nan)
        out[rows] = vals
        return out

    def _nonempty(self, name: str, allow_empty: bool) -> tuple[list[str], np.ndarray, int]:
        """The non-empty cells of a column and their row indices (an empty cell is exactly '')."""
        cells = self.cells[name]
        if "" not in cells:
            return list(cells), np.arange(len(cells)), len(cells)
        filled = np.fromiter(map(len, cells), dtype=np.int64, count=len(cells)) > 0
        if not allow_empty:
            i = int(np.argmin(filled))
            raise SessionFormatError(self.path, "empty cell; this column needs a value on every row",
                                     i + FIRST_DATA_LINE, name)
        rows = np.flatnonzero(filled)
        return [cells[i] for i in rows], rows, len(cells)

    def _convert(self, name: str, values: list[str], rows: np.ndarray, dtype, message: str) -> np.ndarray:
        try:
            return np.array(values, dtype=dtype)
        except (ValueError, OverflowError):
            for value, i in zip(values, rows):
                try:
                    np.array([value], dtype=dtype)
                except (ValueError, OverflowError):
                    raise SessionFormatError(self.path, f"{value!r} {message}", int(i) + FIRST_DATA_LINE,
                                             name) from None
            raise


def _check_increasing(path: Path, t: np.ndarray) -> None:
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise SessionFormatError(path, f"t = {t[i]!r} s is not after the previous row's t = {t[i - 1]!r} s "
                                 "(t must increase monotonically)", i + FIRST_DATA_LINE, "t")


def _check_move_steps(path: Path, is_move: np.ndarray, step: np.ndarray) -> None:
    """A move row carries the step of the hold it leaves (session-csv.md)."""
    hold_rows = np.where(~is_move, np.arange(len(step)), -1)
    last_hold = np.maximum.accumulate(hold_rows)
    bad = is_move & (last_hold >= 0) & (step != step[np.maximum(last_hold, 0)])
    if bad.any():
        i = int(np.argmax(bad))
        raise SessionFormatError(path, f"move row has step {step[i]}, but the hold it leaves has step "
                                 f"{step[last_hold[i]]}", i + FIRST_DATA_LINE, "step")


def _check_hold_runs(path: Path, is_hold: np.ndarray, step: np.ndarray) -> None:
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


def _quaternions(path: Path, col: _ColumnParser) -> np.ndarray:
    q = np.column_stack([col.floats(c) for c in QUAT_COLUMNS])
    norm = np.linalg.norm(q, axis=1)
    bad = np.abs(norm - 1.0) > QUAT_NORM_TOL
    if bad.any():
        i = int(np.argmax(bad))
        raise SessionFormatError(path, f"quaternion norm {norm[i]:.6g} is not 1 (tolerance {QUAT_NORM_TOL:g})",
                                 i + FIRST_DATA_LINE, ",".join(QUAT_COLUMNS))
    q = q / norm[:, None]
    return np.where(q[:, :1] < 0, -q, q)  # q and -q are one rotation; conventions.md stores w >= 0


def _sensor_counts(path: Path, col: _ColumnParser, sensor: str, names: list[str]) -> np.ndarray:
    """Raw counts of one sensor, NaN on rows where it had no new sample (all three cells empty)."""
    y = np.column_stack([col.integers(c, allow_empty=True) for c in names])
    have = ~np.isnan(y)
    partial = have.any(axis=1) & ~have.all(axis=1)
    if partial.any():
        i = int(np.argmax(partial))
        missing = names[int(np.argmin(have[i]))]
        raise SessionFormatError(path, f"sensor {sensor!r} has some but not all of its cells on this row",
                                 i + FIRST_DATA_LINE, missing)
    return y


def write_session(session: SessionData, folder: str | os.PathLike, extra_meta: dict | None = None) -> Path:
    """Write `session` as an interchange folder (created if needed); returns the folder.

    Raw counts are written as integers and NaN as empty cells; keys of `session.meta` that the
    layout does not define are kept, `extra_meta` is merged last.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    meta = _meta_for(session, extra_meta)
    _check_writable(session)
    columns: dict[str, list[str]] = {
        "t": _format_floats(session.t, "t"),
        "phase": np.where(session.is_move, "move", "hold").tolist(),
        "step": [str(int(s)) for s in np.asarray(session.step).tolist()],
    }
    q = np.asarray(session.q_ref, dtype=float)
    for k, name in enumerate(QUAT_COLUMNS):
        columns[name] = _format_floats(q[:, k], name)
    if session.table_deg is not None:
        for k, name in enumerate(TABLE_COLUMNS):
            columns[name] = _format_floats(session.table_deg[:, k], name, allow_nan=True)
    for sensor, names in session.columns.items():
        for k, name in enumerate(names):
            columns[name] = _format_counts(session.raw[sensor][:, k], name)
    if session.temp_c is not None:
        columns["temp_c"] = _format_floats(session.temp_c, "temp_c", allow_nan=True)
    if session.vsupply_v is not None:
        columns["vsupply_v"] = _format_floats(session.vsupply_v, "vsupply_v", allow_nan=True)
    lengths = {len(v) for v in columns.values()}
    if len(lengths) != 1:
        raise ValueError(f"session columns differ in length: { {k: len(v) for k, v in columns.items()} }")
    lines = [",".join(columns)] + [",".join(row) for row in zip(*columns.values())]
    write_text_atomic(folder / SAMPLES_FILE, "\n".join(lines) + "\n")
    write_text_atomic(folder / META_FILE, json.dumps(meta, indent=2, default=_json_default) + "\n")
    return folder


def _check_writable(session: SessionData) -> None:
    """Refuse to write a file that read_session would refuse."""
    bad = np.flatnonzero(np.diff(session.t) <= 0)
    if bad.size:
        raise ValueError(f"t must increase: row {int(bad[0]) + 1} t = {session.t[bad[0] + 1]!r} s")
    norm = np.linalg.norm(np.asarray(session.q_ref, dtype=float), axis=1)
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


def _format_counts(values: np.ndarray, name: str) -> list[str]:
    values = np.asarray(values, dtype=float)
    have = ~np.isnan(values)
    bad = have & ((values != np.round(values)) | ~np.isfinite(values))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"column {name!r}: raw counts must be integers, row {i} holds {values[i]!r}")
    return [str(int(v)) if ok else "" for v, ok in zip(values.tolist(), have.tolist())]
