"""`--store URL|FOLDER`: the central PostgreSQL store or a folder of SQLite sessions, behind one interface
(`PgStore`, `FolderStore`: sessions, metadata, hold means, calibrations, units, pass/fail, session data,
batch results)."""

from __future__ import annotations

from rig.lab.errors import is_database_url
from rig.lab.folder_store import FolderStore


def open_store(store: str, *, write: bool = False):
    """The store named by a `postgresql://` URL or a folder path. `write` only for batch results."""
    if is_database_url(store):
        from rig.lab.pg_store import PgStore

        return PgStore(store, write=write)
    return FolderStore(store)
