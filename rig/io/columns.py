"""Numeric columns of a large delimited text file, read in one pass at C speed, with exact error locations.

The file is streamed line by line into numpy's C parser (`np.loadtxt`), keeping only the columns asked for,
so memory is that of the numbers and time is linear in the rows (a list of Python strings per cell costs
about 2 KiB a row and grows superlinearly). An empty cell reads as NaN. When the parser refuses the file, a
second, streaming pass finds the first offending line and column and says what is wrong there, so a long
recording with one bad cell is not read into memory as strings to be reported.

An empty cell is handed to the parser as a sentinel number, so that a cell that literally says `nan` or `inf`
is still told apart from an empty one and refused (a sensor that wrote `nan` did not just skip a sample).
Integer columns (raw counts, steps) are parsed as integers, so `1e3` or `12.5` there is refused as the
integer it is not.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.text_file import first_line_not_utf8

FIRST_DATA_LINE = 2
EMPTY = "-9223372036854775807"      # an empty cell inside the C parser (an int64 and a float); NaN once parsed
EMPTY_INT = -9223372036854775807
EMPTY_FLOAT = float(EMPTY)
INTEGER = re.compile(r"[+-]?\d+")


def read_header(path: Path, delimiter: str = ",", header_line: int = 1) -> list[str]:
    """The header row's names, stripped; an empty or repeated name is an error naming the file and the line.
    `header_line` is where it is (1-based): a logger that prints its settings above the columns."""
    first = _line(path, header_line)
    if not first.strip():
        raise SessionFormatError(path, "empty file: a header row is required" if header_line == 1 else
                                 "no header row here (the line is empty or beyond the end of the file)", header_line)
    header = [h.strip() for h in next(csv.reader([first], delimiter=delimiter))]
    seen: set[str] = set()
    for name in header:
        if not name:
            raise SessionFormatError(path, "empty column name in the header", header_line)
        if name in seen:
            raise SessionFormatError(path, "column named twice in the header", header_line, name)
        seen.add(name)
    return header


def numbered_columns(path: Path, delimiter: str = ",") -> list[str]:
    """A file without a header: its columns named by number from 1 ("1", "2", ...), as many as its first line
    has cells."""
    first = _line(path, 1)
    if not first.strip():
        raise SessionFormatError(path, "no data on the first line (a file without a header starts with its data)", 1)
    return [str(k) for k in range(1, len(next(csv.reader([first], delimiter=delimiter))) + 1)]


def _line(path: Path, line_no: int) -> str:
    """Line `line_no` (1-based) of a text file, "" beyond its end; a file that cannot be read is named."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            for _ in range(line_no - 1):
                f.readline()
            return f.readline()
    except FileNotFoundError:
        raise SessionFormatError(path, "no such file") from None
    except OSError as exc:
        raise SessionFormatError(path, f"cannot be read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise SessionFormatError(path, *reversed(first_line_not_utf8(path))) from None


def header_line_holding(path: Path, names: list[str], delimiter: str = ",", within: int = 100) -> int | None:
    """The first of the file's first `within` lines whose cells hold every one of `names` (1-based), or None:
    where a header that is not on line 1 is, to tell the user which `--header-line` to give."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            for line_no, line in enumerate(f, 1):
                if line_no > within:
                    break
                cells = {c.strip() for c in next(csv.reader([line], delimiter=delimiter), [])}
                if set(names) <= cells:
                    return line_no
    except (OSError, UnicodeDecodeError):
        return None
    return None


def read_columns(path: Path, header: list[str], numeric: list[str], text: list[str] = (), *,
                 integers: tuple[str, ...] = (), delimiter: str = ",",
                 required: tuple[str, ...] = (), header_line: int = 1) -> dict[str, np.ndarray]:
    """The named columns of every data row: `numeric` as float64 (NaN where empty; those also in `integers` must
    hold integer literals), `text` as str arrays.

    `required` columns may not have an empty cell. Raises SessionFormatError naming the line and column of
    the first cell that is not a (finite) number or integer, a row with the wrong number of cells, or an empty
    required cell.
    """
    try:
        return _read_columns(path, header, numeric, text, integers, delimiter, required, header_line)
    except UnicodeDecodeError:                         # streamed: the decoder's position is not the file's
        raise SessionFormatError(path, *reversed(first_line_not_utf8(path))) from None


def _read_columns(path: Path, header: list[str], numeric: list[str], text: list[str], integers: tuple[str, ...],
                  delimiter: str, required: tuple[str, ...], header_line: int) -> dict[str, np.ndarray]:
    index = {name: header.index(name) for name in [*numeric, *text]}
    first = header_line + 1
    out: dict[str, np.ndarray] = {}
    if numeric:
        dtype = np.dtype([(f"c{k}", "i8" if name in integers else "f8") for k, name in enumerate(numeric)])
        try:
            values = np.loadtxt(_numeric_lines(path, header, delimiter, header_line), delimiter=delimiter,
                                usecols=[index[n] for n in numeric], dtype=dtype, ndmin=1, comments=None)
        except SessionFormatError:
            raise            # from _numeric_lines, already naming its line (a ValueError: not to be wrapped again)
        except (ValueError, IndexError, OverflowError) as exc:
            _raise_first_problem(path, header, numeric, integers, delimiter, required, header_line)
            raise SessionFormatError(path, f"cannot be read as numbers: {exc}") from None
        if values.shape[0] == 0:
            raise SessionFormatError(path, "no data rows after the header", first)
        for k, name in enumerate(numeric):
            raw = values[f"c{k}"]
            empty = raw == (EMPTY_INT if name in integers else EMPTY_FLOAT)
            column = raw.astype(np.float64)
            bad = ~np.isfinite(column)
            if bad.any():
                i = int(np.argmax(bad))
                raise SessionFormatError(path, f"{column[i]!r} is not a finite number (leave the cell empty for "
                                         "'no sample')", i + first, name)
            column[empty] = np.nan
            if name in required and empty.any():
                raise SessionFormatError(path, "empty cell; this column needs a value on every row",
                                         int(np.argmax(empty)) + first, name)
            out[name] = column
        del values
    for name in text:
        lines = (line for _, line in _text_lines(path, header_line))
        out[name] = np.char.strip(np.loadtxt(lines, delimiter=delimiter, usecols=[index[name]], dtype="U32", ndmin=1,
                                             comments=None, quotechar='"'))
    return out


def _text_lines(path: Path, header_line: int = 1) -> Iterator[tuple[int, str]]:
    """The data lines, after the header; blank lines may only end the file (elsewhere they would shift every
    line number)."""
    with open(path, encoding="utf-8-sig", newline="") as f:
        for _ in range(header_line):
            next(f, None)
        blank = None
        for line_no, line in enumerate(f, header_line + 1):
            line = line.rstrip("\r\n")
            if not line.strip():
                blank = blank or line_no
                continue
            if blank is not None:
                raise SessionFormatError(path, "empty row inside the data (only the end of the file may be blank)",
                                         blank)
            yield line_no, line


def _numeric_lines(path: Path, header: list[str], delimiter: str, header_line: int = 1) -> Iterator[str]:
    """Data lines with every empty cell written as the EMPTY sentinel for the C parser; a line with another
    number of cells than the header is refused here (the parser, reading only some columns, would not)."""
    empty = delimiter + delimiter
    filled = delimiter + EMPTY + delimiter
    width = len(header)
    for line_no, line in _text_lines(path, header_line):
        if line.count(delimiter) != width - 1 and '"' not in line:
            cells = line.count(delimiter) + 1
            raise SessionFormatError(path, f"row has {cells} cells, {_first(header_line)} has {width}", line_no,
                                     header[cells] if cells < width else None)
        if (" " in line or "\t" in line) and '"' not in line:
            # Cells padded with blanks ("1, 2, , 4", as printf-style loggers write them): the header's names and
            # the second pass strip them, so the parser must too; a blank-only cell reached it as " " and the
            # user got the parser's "row 1, column 16" instead of a line of the file.
            line = delimiter.join(cell.strip() for cell in line.split(delimiter))
        if empty in line:
            line = line.replace(empty, filled).replace(empty, filled)
        if line.startswith(delimiter):
            line = EMPTY + line
        if line.endswith(delimiter):
            line += EMPTY
        yield line


def _raise_first_problem(path: Path, header: list[str], numeric: list[str], integers: tuple[str, ...],
                         delimiter: str, required: tuple[str, ...], header_line: int = 1) -> None:
    """Stream the rows again to name the first bad one; returns only if it finds nothing (then the caller
    reports the parser's own error)."""
    cols = [(name, header.index(name)) for name in numeric]
    with open(path, encoding="utf-8-sig", newline="") as f:
        for _ in range(header_line):
            f.readline()
        reader = csv.reader(f, delimiter=delimiter)
        rows = 0
        for line_no, row in enumerate(reader, header_line + 1):
            if not row or not "".join(row).strip():
                continue
            rows += 1
            if len(row) != len(header):
                column = header[len(row)] if len(row) < len(header) else None
                raise SessionFormatError(path, f"row has {len(row)} cells, {_first(header_line)} has {len(header)}",
                                         line_no, column)
            for name, i in cols:
                cell = row[i].strip()
                if not cell:
                    if name in required:
                        raise SessionFormatError(path, "empty cell; this column needs a value on every row", line_no,
                                                 name)
                    continue
                if name in integers:
                    if not INTEGER.fullmatch(cell):
                        raise SessionFormatError(path, f"{cell!r} is not an integer", line_no, name)
                    continue
                try:
                    value = float(cell)
                except ValueError:
                    raise SessionFormatError(path, f"{cell!r} is not a number", line_no, name) from None
                if not np.isfinite(value):
                    raise SessionFormatError(path, f"{cell!r} is not a finite number (leave the cell empty for "
                                             "'no sample')", line_no, name)
        if rows == 0:
            raise SessionFormatError(path, "no data rows after the header", header_line + 1)


def cell_text(path: Path, line_no: int, column: str, delimiter: str = ",") -> str:
    """The text of one cell as written in the file (for a message that quotes what the user wrote)."""
    header = read_header(path, delimiter)
    with open(path, encoding="utf-8-sig", newline="") as f:
        for k, row in enumerate(csv.reader(f, delimiter=delimiter), 1):
            if k == line_no:
                return row[header.index(column)].strip() if column in header and len(row) > header.index(column) \
                    else ""
    return ""


def _first(header_line: int) -> str:
    return "the header" if header_line else "the first row"
