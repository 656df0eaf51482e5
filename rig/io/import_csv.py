"""Any logger's CSV as a recording without a turntable, given its column map on the command line.

The user names the time column and its unit (or the sample rate, when the file has none), the three columns of
each sensor and the units they are in; nothing is guessed from the data. Errors name the file, line and column.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rig.errors import InputError, SessionFormatError
from rig.io.columns import header_line_holding, numbered_columns, read_columns, read_header
from rig.io.import_checks import check_rate, check_samples
from rig.io.recording import STANDARD_GRAVITY, check_counts, recording_session, to_session_units
from rig.session_data import SessionData

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}


def import_csv(path: str | os.PathLike, sensors: dict[str, list[str]], *, units: dict[str, str],
               time_column: str | None = None, time_unit: str = "s", rate_hz: float | None = None,
               temp_column: str | None = None, delimiter: str = ",", gravity: float = STANDARD_GRAVITY,
               field_uT: float | None = None, header_line: int = 1,
               initial_rest_s: float | None = None) -> SessionData:
    """`sensors`: sensor -> its three column names (sensor axes x, y, z); `units`: sensor -> unit of those;
    `header_line`: the line of the column names (1-based), for a logger that prints its settings above them; 0
    for a file without them (imu_tk's and many loggers' plain numbers), whose columns are named "1", "2", ..."""
    path = Path(path)
    if (time_column is None) == (rate_hz is None):
        raise InputError("give either --time COLUMN (with --time-unit) or --rate-hz R for a file without time stamps")
    if time_unit not in TIME_UNITS:
        raise InputError(f"--time-unit {time_unit!r}: one of {', '.join(TIME_UNITS)}")
    if rate_hz is not None and not (np.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"--rate-hz {rate_hz!r}: must be a positive number")
    if header_line < 0:
        raise InputError(f"--header-line {header_line}: lines count from 1 (0: the file has no header)")
    header = read_header(path, delimiter, header_line) if header_line else numbered_columns(path, delimiter)
    wanted = [*([time_column] if time_column else []), *(c for cols in sensors.values() for c in cols),
              *([temp_column] if temp_column else [])]
    for name in wanted:
        if name not in header and not header_line:
            raise SessionFormatError(path, f"column {name!r} (named on the command line) is not in the file: its first "
                                     f"line has {len(header)} cell{'s' if len(header) != 1 else ''} separated by {delimiter!r}, "
                                     f"columns 1 to {len(header)}", 1, name)
        if name not in header:
            there = header_line_holding(path, wanted, delimiter) if header_line else None
            hint = f"; line {there} has every column named: give --header-line {there}" if there else ""
            if not there and header_line and all(c.isdigit() for c in wanted) and _all_numbers(header):
                hint = "; the file has no header: give --header-line 0, and the columns by number from 1"
            raise SessionFormatError(path, f"column {name!r} (named on the command line) is not in the header; it has "
                                     f"{', '.join(header)}{hint}", header_line, name)
    if len(set(wanted)) != len(wanted):
        twice = next(c for c in wanted if wanted.count(c) > 1)
        raise InputError(f"column {twice!r} is named twice on the command line")
    first = header_line + 1
    cols = read_columns(path, header, wanted, delimiter=delimiter,
                        required=(*([time_column] if time_column else []),), header_line=header_line)
    n = len(cols[wanted[0]])
    if time_column:
        t = cols[time_column] * TIME_UNITS[time_unit]
        back = np.flatnonzero(np.diff(t) <= 0)
        if back.size:
            i = int(back[0]) + 1
            raise SessionFormatError(path, f"time {cols[time_column][i]:g} {time_unit} is not after the previous row's "
                                     f"{cols[time_column][i - 1]:g}", i + first, time_column)
        check_rate(path, t, time_column, time_unit)
    else:
        t = np.arange(n) / float(rate_hz)
    raw = {s: np.column_stack([cols[c] for c in names]) for s, names in sensors.items()}
    for sensor, names in sensors.items():
        # An empty cell is "no sample from that sensor on this row", which is said of all three axes or none: the
        # session written with a half-empty sample was refused by every command that read it, naming a line of
        # its samples.csv the user never wrote. Refused here, at the line and column of the user's file.
        empty = np.isnan(raw[sensor])
        partial = np.flatnonzero(empty.any(axis=1) & ~empty.all(axis=1))
        if partial.size:
            i = int(partial[0])
            given = ", ".join(n for k, n in enumerate(names) if not empty[i, k])
            raise SessionFormatError(path, f"empty cell, but the {sensor}'s {given} on this row have a value; a "
                                     "sample has all three axes or none", i + first,
                                     names[int(np.argmax(empty[i]))])
    lines = np.arange(n) + first
    check_counts(raw, units, {s: (str(path), names, lines) for s, names in sensors.items()})
    with np.errstate(over="ignore"):
        raw, kept = to_session_units(raw, units)
    check_samples(path, cols, sensors, units, raw, kept, first, temp_column)
    rate = rate_hz if rate_hz is not None else (float(1.0 / np.median(np.diff(t))) if n > 1 else None)
    return recording_session(t, raw, units=kept, gravity=gravity, field_uT=field_uT, sample_rate_hz=rate,
                             temp_c=cols[temp_column] if temp_column else None, source=str(path),
                             initial_rest_s=initial_rest_s,
                             imported={"format": "csv", "file": str(path), "columns": sensors,
                                       "units": units, "time": time_column or f"rows at {rate_hz:g} Hz",
                                       **({"header_line": header_line} if header_line != 1 else {}),
                                       **({"time_unit": time_unit} if time_column else {})})


def _all_numbers(cells: list[str]) -> bool:
    try:
        return all(np.isfinite(float(c)) for c in cells)
    except ValueError:
        return False
