"""The space a session keeps in hand so that a full disk cannot leave it marked "running".

The store keeps a small reserve file beside the session (`.space-reserve`, written when the session is created
or reopened for writing) and gives its space back when a status cannot be written otherwise, so the last word
on a session is always recorded.
"""

from __future__ import annotations

import os
from pathlib import Path

RESERVE_FILE = ".space-reserve"
RESERVE_BYTES = 1 << 20


class SpaceReserve:
    """The reserve file in one session folder."""

    def __init__(self, folder: Path) -> None:
        self.path = folder / RESERVE_FILE

    def keep(self) -> None:
        """(Re)write the reserve file, so a status can still be written when the disk fills up."""
        try:
            if self.path.is_file() and self.path.stat().st_size >= RESERVE_BYTES:
                return
            with open(self.path, "wb") as f:
                f.write(bytes(RESERVE_BYTES))
                f.flush()
                os.fsync(f.fileno())
        except OSError:
            self.path.unlink(missing_ok=True)     # no room for it: the session can still run

    def release(self) -> bool:
        """Give the reserve's space back; False if there was none."""
        if not self.path.exists():
            return False
        self.path.unlink()
        return True
