"""Why a session file could not be written, in words a user can act on.

SQLite says "disk I/O error" for a full disk, a file-size limit on the process (ulimit -f) and a failing or
removed disk alike; the user needs to know which of them to fix before `rig resume`.
"""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

try:
    import resource
except ImportError:        # not on Windows: no file-size limit to name there
    resource = None

from rig.store.space_reserve import RESERVE_BYTES


def why(exc: sqlite3.Error, path: Path | None = None) -> str:
    """SQLite's message, with the cause a user can act on when it is a write that failed."""
    text = str(exc)
    code = getattr(exc, "sqlite_errorcode", None)
    if "full" in text or code == sqlite3.SQLITE_FULL:
        return f"{text} (the disk is full: free some space, then `rig resume`)"
    if path is not None and code is not None and code & 0xFF == sqlite3.SQLITE_IOERR:
        return f"{text} ({_write_failure(Path(path))})"
    return text


def _write_failure(path: Path) -> str:
    """Why a write to the session folder failed: a file-size limit on this process (ulimit -f: EFBIG), a full
    disk (sometimes said as an I/O error), or the disk itself."""
    folder = path.parent
    try:
        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    except (AttributeError, OSError, ValueError):
        limit = None
    if limit is not None and limit != getattr(resource, "RLIM_INFINITY", -1):
        sizes = [f.stat().st_size for f in folder.glob(path.name + "*") if f.is_file()]
        if sizes and max(sizes) + 65536 >= limit:
            return (f"this process may not write files over {limit} bytes (file-size limit, ulimit -f) and the "
                    "session has reached it: raise the limit, then `rig resume`")
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        free = None
    if free is not None and free < RESERVE_BYTES:
        return f"the disk is full ({free} bytes free): free some space, then `rig resume`"
    return "writing to the disk failed (removed, read-only or failing?); check it, then `rig resume`"
