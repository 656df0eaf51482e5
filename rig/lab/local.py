"""A rig session folder read without touching it, for pushing and for the folder store.

The file is opened read-only (`mode=ro`): in WAL mode a reader sees every committed transaction of the rig
writing beside it and never blocks it. Nothing here writes to the folder. The reader takes the layout from
`rig.store.schema` and reads the columns it needs by name, so extra metadata keys, statuses or columns a
later rig adds are carried along rather than refused.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from rig.io.session_format import META_FILE, SAMPLES_FILE
from rig.lab.errors import StoreInputError
from rig.store.schema import APPLICATION_ID, LAYOUT_VERSION, SESSION_FILE

CALIBRATION_FILE = "calibration.json"
ARTIFACT_SUFFIXES = {".md": "text/markdown", ".json": "application/json", ".png": "image/png",
                     ".svg": "image/svg+xml"}
# the first value of these keys (written when the session was created, never changed) names the session
IDENTITY_KEYS = ("start_utc", "host", "unit", "operator", "config", "schedule", "seed", "trial")


@dataclass
class Segment:
    seq: int                      # the segment's id in the session file, its natural key within the session
    phase: str
    step: int
    attempt: int
    t_start: float
    t_end: float
    n_rows: int
    angles: tuple                 # commanded outer, inner, measured outer, inner (None for a move)
    written_utc: str
    arrays: list[tuple[str, str, str, bytes]] = field(default_factory=list)    # name, dtype, shape, data
    stats: list[tuple[str, float | None, float | None, int]] = field(default_factory=list)

    @property
    def digest(self) -> str:
        """What the segment is, bytes included: two copies agree on it, a different recording does not."""
        h = hashlib.sha256(json.dumps([self.phase, self.step, self.attempt, repr(self.t_start), repr(self.t_end),
                                       self.n_rows, [repr(a) for a in self.angles]]).encode())
        for name, dtype, shape, data in sorted(self.arrays):
            h.update(f"{name}|{dtype}|{shape}|{len(data)}".encode())
            h.update(data)
        return h.hexdigest()

    def describe(self) -> str:
        return f"{self.phase} step {self.step} attempt {self.attempt} (t {self.t_start:.3f}..{self.t_end:.3f} s)"


class LocalSession:
    """One session folder, read-only. Use as a context manager."""

    def __init__(self, folder: Path, conn: sqlite3.Connection) -> None:
        self.folder = Path(folder)
        self._conn = conn

    @classmethod
    def open(cls, folder: str | Path) -> "LocalSession":
        folder = Path(folder)
        path = folder / SESSION_FILE
        if not folder.is_dir():
            raise StoreInputError(f"{folder}: no such session folder")
        if not path.is_file():
            raise StoreInputError(f"{folder}: not a rig session (no {SESSION_FILE})")
        try:
            conn = sqlite3.connect(path.resolve().as_uri() + "?mode=ro", uri=True, timeout=5.0,
                                   isolation_level=None, check_same_thread=False)
            app_id = conn.execute("PRAGMA application_id").fetchone()[0]
            version = conn.execute("PRAGMA user_version").fetchone()[0]
        except sqlite3.Error as exc:
            raise StoreInputError(f"{path}: not a readable session file ({exc})") from None
        if app_id != APPLICATION_ID:
            conn.close()
            raise StoreInputError(f"{path}: an SQLite file but not a rig session (application_id {app_id:#x})")
        if version > LAYOUT_VERSION:
            conn.close()
            raise StoreInputError(f"{path}: layout version {version} is newer than this rig reads ({LAYOUT_VERSION})")
        return cls(folder, conn)

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> "LocalSession":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _rows(self, sql: str, args=()) -> list[tuple]:
        try:
            return self._conn.execute(sql, args).fetchall()
        except sqlite3.Error as exc:
            raise StoreInputError(f"{self.folder / SESSION_FILE}: cannot be read ({exc})") from None

    # -- metadata ---------------------------------------------------------------------------------
    def metadata_rows(self, after: int = 0) -> list[tuple[int, str, str, str]]:
        """(seq, key, JSON text, written_utc) of the metadata history after `after`."""
        return self._rows("SELECT id, key, value, written_utc FROM metadata WHERE id > ? ORDER BY id", (after,))

    def metadata(self) -> dict:
        return {key: _loads(value) for _, key, value, _ in self.metadata_rows()}

    def identity(self) -> dict:
        """The first value of each identity key: what the session was when it was created."""
        first: dict = {}
        for _, key, value, written in self.metadata_rows():
            if key in IDENTITY_KEYS and key not in first:
                first[key] = _loads(value)
            first.setdefault("_first_written", written)
        return first

    def key(self) -> str:
        """The session's natural key, a UUID made from its identity: the same for every copy of the folder."""
        ident = self.identity()
        ident.setdefault("start_utc", ident.get("_first_written"))
        ident.pop("_first_written", None)
        text = json.dumps(ident, sort_keys=True, default=str)
        return str(uuid.UUID(bytes=hashlib.sha256(text.encode()).digest()[:16]))

    def last_ids(self) -> tuple[int, int, int]:
        """(metadata, segment, event) latest ids: a cheap way to see whether anything new was committed."""
        return tuple(int(self._rows(f"SELECT coalesce(max(id), 0) FROM {table}")[0][0])
                     for table in ("metadata", "segment", "event"))

    # -- segments and events ----------------------------------------------------------------------
    def segments(self, after: int = 0, upto: int | None = None, with_data: bool = True) -> list[Segment]:
        """Committed segments with seq in (after, upto], with their arrays and hold statistics."""
        bound = "" if upto is None else f" AND id <= {int(upto)}"
        rows = self._rows("SELECT id, phase, step, attempt, t_start, t_end, n_rows, commanded_outer_deg, "
                          "commanded_inner_deg, measured_outer_deg, measured_inner_deg, written_utc FROM segment "
                          f"WHERE id > ?{bound} ORDER BY id", (after,))
        segments = {r[0]: Segment(int(r[0]), r[1], int(r[2]), int(r[3]), float(r[4]), float(r[5]), int(r[6]),
                                  tuple(r[7:11]), r[11]) for r in rows}
        if segments and with_data:
            lo, hi = min(segments), max(segments)
            for seg, name, dtype, shape, data in self._rows(
                    "SELECT segment_id, name, dtype, shape, data FROM array WHERE segment_id BETWEEN ? AND ?",
                    (lo, hi)):
                if seg in segments:
                    segments[seg].arrays.append((name, dtype, shape, bytes(data)))
            for seg, channel, mean, std, count in self._rows(
                    "SELECT segment_id, channel, mean, std, count FROM hold_stat WHERE segment_id BETWEEN ? AND ?",
                    (lo, hi)):
                if seg in segments:
                    segments[seg].stats.append((channel, mean, std, int(count)))
        return list(segments.values())

    def hold_summary(self) -> tuple[int, str | None, str | None]:
        """(distinct hold steps, first and last hold written_utc)."""
        n, first, last = self._rows("SELECT count(DISTINCT step), min(written_utc), max(written_utc) FROM segment "
                                    "WHERE phase = 'hold'")[0]
        return int(n), first, last

    def hold_mean_rows(self) -> list[tuple]:
        """(seq, step, attempt, written_utc, channel, mean) of every hold."""
        return self._rows("SELECT s.id, s.step, s.attempt, s.written_utc, h.channel, h.mean FROM segment s "
                          "LEFT JOIN hold_stat h ON h.segment_id = s.id WHERE s.phase = 'hold' ORDER BY s.id")

    @property
    def connection(self) -> sqlite3.Connection:
        return self._conn

    def events(self, after: int = 0) -> list[tuple[int, float | None, str, str, str]]:
        return self._rows("SELECT id, t, kind, message, written_utc FROM event WHERE id > ? ORDER BY id", (after,))

    # -- files beside the session -----------------------------------------------------------------
    def calibration_text(self) -> str | None:
        path = self.folder / CALIBRATION_FILE
        try:
            return path.read_text()
        except (FileNotFoundError, NotADirectoryError):
            return None
        except OSError as exc:
            raise StoreInputError(f"{path}: cannot be read ({exc.strerror})") from None

    def artifacts(self) -> list[tuple[str, str, bytes]]:
        """(name, media type, bytes) of the report and its plots written beside the session."""
        out = []
        for path in sorted(self.folder.iterdir()):
            media = ARTIFACT_SUFFIXES.get(path.suffix)
            if media and path.is_file() and path.name != CALIBRATION_FILE and not path.name.startswith("."):
                try:
                    out.append((path.name, media, path.read_bytes()))
                except OSError as exc:
                    raise StoreInputError(f"{path}: cannot be read ({exc.strerror})") from None
        return out


def _loads(text: str):
    try:
        return json.loads(text)
    except ValueError:
        return text


def session_folders(root: str | Path) -> list[Path]:
    """Every session folder under `root` (itself included), sorted."""
    root = Path(root)
    if not root.is_dir():
        raise StoreInputError(f"{root}: no such folder")
    return sorted(p.parent for p in root.rglob(SESSION_FILE) if p.is_file())


def interchange_folders(root: str | Path) -> list[Path]:
    """Folders under `root` laid out as interchange sessions (`meta.json` beside `samples.csv`, session-csv.md):
    imported recordings and exports, which the store does not read as sessions of its own, so a command that
    finds none of those can say what it found instead."""
    root = Path(root)
    return sorted(p.parent for p in root.rglob(SAMPLES_FILE) if (p.parent / META_FILE).is_file())
