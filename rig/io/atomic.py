"""Atomic file writes: a reader never sees a half-written calibration or session file."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text_atomic(path: str | os.PathLike, text: str | Iterable[str]) -> Path:
    """Write `text` (or its pieces, in order) to a temporary file beside `path`, fsync it, then `os.replace` it
    into place. Pieces let a long recording be written without holding all its text at once.

    The file gets the permissions an ordinary `open()` would give (0666 less the umask): other programs
    read calibration files, and mkstemp's private 0600 would lock them out.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as f:
            if isinstance(text, str):
                f.write(text)
            else:
                for piece in text:
                    f.write(piece)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path
