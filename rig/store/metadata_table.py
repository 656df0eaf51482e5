"""The session's `metadata` table: values of any key as JSON rows, appended, read back as each key's latest.

A metadata change is a new row for the same key, never an overwrite (see `schema.py`), so every writer appends
the rows `encode_metadata` makes and a reader takes the latest row of each key.
"""

from __future__ import annotations

import json
import sqlite3
from datetime import datetime
from pathlib import Path

import numpy as np

from rig.store.schema import utc_now


def encode_metadata(path: Path, values: dict) -> list[tuple[str, str, str]]:
    """(key, JSON value, written_utc) rows; a ValueError naming the session `path` and the key if a value is
    not JSON-serialisable (numpy arrays and scalars, paths and datetimes are)."""
    now = utc_now()
    rows = []
    for key, value in values.items():
        try:
            rows.append((key, json.dumps(value, default=_jsonable), now))
        except TypeError as exc:
            raise ValueError(f"{path}: metadata key {key!r} is not JSON-serialisable ({exc})") from exc
    return rows


def insert_metadata(db: sqlite3.Connection, rows: list[tuple[str, str, str]]) -> None:
    db.executemany("INSERT INTO metadata (key, value, written_utc) VALUES (?, ?, ?)", rows)


def latest_metadata(db: sqlite3.Connection) -> dict:
    """Latest value of every metadata key."""
    rows = db.execute("SELECT key, value FROM metadata ORDER BY id").fetchall()
    return {key: json.loads(value) for key, value in rows}


def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (Path, datetime)):
        return str(value) if isinstance(value, Path) else value.isoformat()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")
