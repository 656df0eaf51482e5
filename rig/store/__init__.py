"""Crash-safe, append-only storage of calibration sessions (one SQLite file per session folder)."""

from rig.store.schema import FORMAT, SESSION_FILE
from rig.store.session_store import SessionStore
from rig.store.sqlite_file import NotASession, SessionStoreError

__all__ = ["FORMAT", "SESSION_FILE", "NotASession", "SessionStore", "SessionStoreError"]
