"""Text files as the rig reads them: UTF-8, a byte-order mark allowed (Windows editors write one).

A file in another encoding (a Latin-1 degree sign from a logger, a UTF-16 file from PowerShell's `>`) had reached
users as a Python decoding error: an internal error (exit 70) from `rig discrepancy` and `rig noise`, "cannot be
calibrated" (exit 3) from `rig calibrate --from`. The readers now name the file, its first line that is not UTF-8
and the byte there, as bad input.
"""

from __future__ import annotations

import io
from collections.abc import Callable
from pathlib import Path

UTF16_MARKS = (b"\xff\xfe", b"\xfe\xff")


def read_utf8(path: Path, fail: Callable[[str, int | None], Exception], missing: str = "no such file") -> str:
    """The file's text; `fail(message, line)` makes the error for a file that is missing, unreadable or not
    UTF-8 (line None where no line is to blame)."""
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise fail(missing, None) from None
    except OSError as exc:
        raise fail(f"cannot be read: {exc.strerror}", None) from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        line, message = not_utf8(io.BytesIO(data))                # lines as the streamed readers count them
        raise fail(message, line) from None


def first_line_not_utf8(path: Path) -> tuple[int | None, str]:
    """The first line of a file that is not UTF-8, and what is there; read line by line (a file of millions of
    rows whose streamed decoding failed)."""
    with open(path, "rb") as f:
        return not_utf8(f)


def not_utf8(lines) -> tuple[int | None, str]:
    for line_no, raw in enumerate(lines, 1):
        if line_no == 1 and raw.startswith(UTF16_MARKS):
            return 1, "UTF-16 text; save it as UTF-8"
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            column = len(raw[:exc.start].decode("utf-8", "replace")) + 1
            return line_no, f"not UTF-8 text: byte 0x{raw[exc.start]:02x} at character {column}; save it as UTF-8"
    return None, "not UTF-8 text; save it as UTF-8"
