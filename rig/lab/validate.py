"""What a session folder must be before any of it enters the central store: every file and record checked
against its published format, refused with the file and the reason (`CorruptInput`, exit 2).

- `session.sqlite` (`rig-session-sqlite/1`, `rig.store.schema`): SQLite's own integrity check, our
  application id and layout version, every table and column of the layout; then each record: a metadata
  value is JSON, a time is a time, a segment's arrays decode to the shapes and values the session store
  writes (`rig.store.segment.checked_arrays`, the writer's own check), its row count and time span are its
  samples', and its hold statistics are those of its samples (`rig.store.segment.hold_stat_rows`).
- `calibration.json` (`rig-calibration/1`): `rig.io.calibration_json.read_calibration`, the reader every
  command uses.
- The report's files: a `.json` is JSON, a `.md` or `.svg` is UTF-8 text, a `.png` is a whole PNG.

The store is append-only and its readers trust what it holds: a file let in there would become a unit's
latest calibration, or a session no question can read. So a push checks first and writes after.
"""

from __future__ import annotations

import json
import math
import sqlite3
from pathlib import Path

import numpy as np

from rig.errors import InputError
from rig.io.calibration_json import read_calibration
from rig.lab.errors import CorruptInput
from rig.lab.identity import parse_utc
from rig.lab.local import CALIBRATION_FILE, LocalSession, Segment
from rig.store import arrays
from rig.store.schema import SESSION_FILE, create_tables
from rig.store.segment import checked_arrays, hold_stat_rows

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_END = b"IEND\xaeB`\x82"
SEGMENT_CHUNK = 64               # segments read at a time when a whole session is checked


def expected_columns() -> dict[str, set[str]]:
    """Every table of the session layout and its columns, from the layout's own DDL."""
    db = sqlite3.connect(":memory:")
    try:
        create_tables(db)
        tables = [r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table' "
                                           "AND name NOT LIKE 'sqlite_%'")]
        return {t: {r[1] for r in db.execute(f"PRAGMA table_info({t})")} for t in tables}
    finally:
        db.close()


LAYOUT = expected_columns()


def check_file(local: LocalSession) -> None:
    """The session file as a whole: SQLite's integrity and the layout's tables and columns."""
    path = local.folder / SESSION_FILE
    conn = local.connection
    try:
        problems = [row[0] for row in conn.execute("PRAGMA integrity_check(5)")]
        present = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        columns = {t: {r[1] for r in conn.execute(f"PRAGMA table_info({t})")} for t in LAYOUT if t in present}
    except sqlite3.DatabaseError as exc:
        raise CorruptInput(f"{path}: a damaged session file ({exc})") from None
    if problems != ["ok"]:
        raise CorruptInput(f"{path}: a damaged session file (SQLite's integrity check: {'; '.join(problems[:3])})")
    for table, wanted in LAYOUT.items():
        if table not in columns:
            raise CorruptInput(f"{path}: table {table!r} of the session layout is missing")
        missing = sorted(wanted - columns[table])
        if missing:
            raise CorruptInput(f"{path}: table {table!r} lacks column {missing[0]!r} of the session layout")


def check_metadata(local: LocalSession, rows: list[tuple]) -> None:
    """(seq, key, JSON text, written_utc) rows: each value is JSON, each time a time."""
    path = local.folder / SESSION_FILE
    for seq, key, value, written in rows:
        where = f"{path}: metadata row {seq} ({key!r})"
        if not isinstance(key, str) or not key:
            raise CorruptInput(f"{path}: metadata row {seq} has no key")
        try:
            parsed = json.loads(value)
        except (TypeError, ValueError) as exc:
            raise CorruptInput(f"{where}: the value is not JSON ({exc})") from None
        _time(where, "written_utc", written)
        if key in ("start_utc", "end_utc") and parsed is not None:
            _time(where, "value", parsed)


def check_events(local: LocalSession, rows: list[tuple]) -> None:
    path = local.folder / SESSION_FILE
    for seq, t, kind, message, written in rows:
        where = f"{path}: event {seq}"
        if t is not None and not (isinstance(t, (int, float)) and math.isfinite(t)):
            raise CorruptInput(f"{where}: its time t is {t!r}, not a finite number")
        if not isinstance(kind, str) or not kind or not isinstance(message, str):
            raise CorruptInput(f"{where}: kind and message must be text")
        _time(where, "written_utc", written)


def check_segment(local: LocalSession, seg: Segment, metadata: dict) -> None:
    """One hold or move: its arrays as the session store writes them, its rows, span and statistics."""
    where = f"{local.folder / SESSION_FILE}: segment {seg.seq} ({seg.describe()})"
    if seg.phase not in ("hold", "move"):
        raise CorruptInput(f"{where}: phase {seg.phase!r} is neither hold nor move")
    _time(where, "written_utc", seg.written_utc)
    try:
        decoded = {name: arrays.decode(dtype, shape, data) for name, dtype, shape, data in seg.arrays}
    except (ValueError, TypeError) as exc:
        raise CorruptInput(f"{where}: an array does not decode ({exc})") from None
    if "t" not in decoded:
        raise CorruptInput(f"{where}: has no time array t")
    samples = {name[4:]: y for name, y in decoded.items() if name.startswith("raw:")}
    try:
        data = checked_arrays(where, decoded["t"], samples, decoded.get("q_ref"), decoded.get("table_deg"),
                              decoded.get("temp_c"), decoded.get("vsupply_v"))
    except (ValueError, TypeError) as exc:
        raise CorruptInput(str(exc) if str(exc).startswith(where) else f"{where}: {exc}") from None
    t = data["t"]
    if seg.n_rows != t.size:
        raise CorruptInput(f"{where}: n_rows says {seg.n_rows}, its arrays hold {t.size} rows")
    if not (_same(seg.t_start, t[0]) and _same(seg.t_end, t[-1])):
        raise CorruptInput(f"{where}: its span {seg.t_start!r}..{seg.t_end!r} s is not its samples' "
                           f"{float(t[0])!r}..{float(t[-1])!r} s")
    if seg.phase == "hold":
        _check_stats(where, seg, hold_stat_rows(data, metadata))


def _check_stats(where: str, seg: Segment, expected: list[tuple]) -> None:
    stored = {channel: (mean, std, count) for channel, mean, std, count in seg.stats}
    for channel, mean, std, count in expected:
        if channel not in stored:
            raise CorruptInput(f"{where}: no hold statistics for channel {channel!r}")
        s_mean, s_std, s_count = stored[channel]
        if s_count != count or not (_close(s_mean, mean, std, count) and _close(s_std, std, std, count)):
            raise CorruptInput(f"{where}: the hold statistics of {channel!r} (mean {s_mean!r}, std {s_std!r}, "
                               f"count {s_count}) are not those of its samples (mean {mean!r}, std {std!r}, "
                               f"count {count})")


def check_segments(local: LocalSession, metadata: dict, after: int = 0) -> int:
    """Every committed segment after `after`, a chunk at a time; the last seq checked."""
    last = after
    while True:
        chunk = local.segments(last, last + SEGMENT_CHUNK)
        if not chunk:
            upto = local.last_ids()[1]
            if last >= upto:
                return last
            last += SEGMENT_CHUNK                     # a gap in the ids (none are deleted, but be safe)
            continue
        for seg in chunk:
            check_segment(local, seg, metadata)
        last = chunk[-1].seq


def check_calibration(local: LocalSession) -> None:
    path = local.folder / CALIBRATION_FILE
    if not path.exists():
        return
    try:
        read_calibration(path)
    except InputError as exc:
        raise CorruptInput(f"{exc}; a calibration file must be rig-calibration/1 "
                           "(docs/reference/calibration-json.md)") from None
    except OSError as exc:
        raise CorruptInput(f"{path}: cannot be read ({exc.strerror})") from None


def check_artifact(folder: Path, name: str, content: bytes) -> None:
    where = folder / name
    suffix = Path(name).suffix
    if suffix == ".png":
        if not content.startswith(PNG_SIGNATURE) or not content.rstrip(b"\0").endswith(PNG_END):
            raise CorruptInput(f"{where}: not a whole PNG image (its signature or its end is missing)")
        return
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise CorruptInput(f"{where}: not UTF-8 text (byte {exc.start})") from None
    if suffix == ".json":
        try:
            json.loads(text)
        except ValueError as exc:
            raise CorruptInput(f"{where}: not valid JSON ({exc})") from None


def check_files(local: LocalSession) -> None:
    check_calibration(local)
    for name, _, content in local.artifacts():
        check_artifact(local.folder, name, content)


def check_records(local: LocalSession, metadata: dict, *, files: bool) -> int:
    """Every record of the session file (and the calibration and report files when `files`); the last
    segment seq checked. The file itself is `check_file`'s."""
    check_metadata(local, local.metadata_rows())
    check_events(local, local.events())
    last = check_segments(local, metadata)
    if files:
        check_files(local)
    return last


def _time(where: str, field: str, value) -> None:
    try:
        parse_utc(value)
    except (TypeError, ValueError):
        raise CorruptInput(f"{where}: {field} {value!r} is not a time") from None


def _same(a: float, b: float) -> bool:
    return math.isfinite(a) and math.isclose(a, float(b), rel_tol=1e-12, abs_tol=1e-9)


def _close(stored, expected, std, count) -> bool:
    """A stored statistic against the one recomputed from the samples: equal to rounding."""
    if stored is None or expected is None:
        return stored is None and expected is None
    if not (isinstance(stored, (int, float)) and math.isfinite(stored)):
        return False
    scale = abs(expected) + (std or 0.0) + 1.0
    return abs(stored - expected) <= 1e-9 * scale * max(1, int(np.log2(max(count, 2))))
