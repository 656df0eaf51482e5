"""Read imu_tk ASCII sensor files: one row `timestamp x y z` per sample, no header.

This is the layout of the IMU-TK test data (tests/data/imu_tk-xsens): white space separated,
timestamp in seconds, raw counts. imu_tk's own loader (`src/io_utils.cpp`, `importAsciiData`)
skips a malformed line with a console note; here such a line is an error naming file, line and
column, because a silently dropped sample shifts the integration between static intervals.
Commas are accepted as separators too (imu_tk's DATASET_COMMA_SEPARATED), as are blank lines and
`#` comment lines.
"""

from __future__ import annotations

import io
import os
import re
from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.text_file import read_utf8

COLUMNS = ("timestamp", "x", "y", "z")
_SEPARATOR = re.compile(r"[,\s]+")


def read_imu_tk(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Timestamps t (n,) in s and raw readings xyz (n, 3) of one imu_tk file; t strictly increasing."""
    t, xyz, _ = read_imu_tk_lines(path)
    return t, xyz


def read_imu_tk_lines(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """As `read_imu_tk`, with the file line (1-based) each row came from, for messages about a row."""
    path = Path(path)
    text = read_utf8(path, lambda message, line: SessionFormatError(path, message, line))
    lines = text.splitlines()
    numbers = [i for i, s in enumerate(lines) if s.strip() and not s.lstrip().startswith("#")]
    if not numbers:
        raise SessionFormatError(path, "no data rows (expected `timestamp x y z` per line)")
    body = "\n".join(lines[i] for i in numbers).replace(",", " ")
    try:
        data = np.loadtxt(io.StringIO(body), dtype=float, ndmin=2)
    except ValueError:
        data = None
    if data is None or data.shape != (len(numbers), 4) or not np.isfinite(data).all():
        _locate_bad_row(path, lines, numbers)
    data = data.reshape(-1, 4)
    t = data[:, 0]
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        i = int(back[0]) + 1
        raise SessionFormatError(path, f"timestamp {t[i]!r} is not after the previous row's {t[i - 1]!r}",
                                 numbers[i] + 1, "timestamp")
    return t.copy(), data[:, 1:].copy(), np.asarray(numbers) + 1


def _locate_bad_row(path: Path, lines: list[str], numbers: list[int]) -> None:
    for i in numbers:
        cells = [c for c in _SEPARATOR.split(lines[i].strip()) if c]
        if len(cells) != 4:
            raise SessionFormatError(path, f"{len(cells)} values, expected 4 (timestamp x y z)", i + 1,
                                     COLUMNS[min(len(cells), 3)] if len(cells) < 4 else None)
        for name, cell in zip(COLUMNS, cells):
            try:
                value = float(cell)
            except ValueError:
                raise SessionFormatError(path, f"{cell!r} is not a number", i + 1, name) from None
            if not np.isfinite(value):
                raise SessionFormatError(path, f"{cell!r} is not a finite number", i + 1, name)
    raise SessionFormatError(path, "malformed data (no single bad row found)")
