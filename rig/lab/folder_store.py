"""A folder of SQLite sessions as a store: the same questions as the central store, without a server.

Every session folder under the root counts (as `rig push --all ROOT` finds them). Each is read read-only
and its summary cached until its files change. A folder whose session file is damaged, foreign or breaks the
layout (`rig.lab.validate.check_file`), or whose calibration breaks its format, is left out of the answers
and named in `skipped` (folder -> reason), which every command and the page say. Batch results are written beside the session, in its `lab/`
folder (`<kind>-<run>.json`, and `calibration-<run>.json` for a re-calibration); the session file itself is
never touched.
"""

from __future__ import annotations

import json
import re
import threading
from collections import Counter
from datetime import datetime, timezone
from pathlib import Path

from rig.errors import InputError
from rig.io.atomic import write_text_atomic
from rig.io.calibration_json import read_calibration
from rig.lab import identity, sessiondata, validate
from rig.lab.errors import StoreInputError
from rig.lab.local import CALIBRATION_FILE, LocalSession, session_folders
from rig.lab.records import BATCH_PREFIX, RIG_SOURCE, CalibrationRecord, Filters, SessionRow
from rig.session_data import SessionData
from rig.store.schema import SESSION_FILE

RESULTS = "lab"
SAFE_RUN = re.compile(r"^[\w.\-]+$")          # a batch run's id as it names a file (never a path)


class FolderStore:
    kind = "folder"

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            raise StoreInputError(f"{self.root}: no such folder (give a folder of session folders, or a "
                                  "postgresql:// URL)")
        self.url = str(self.root)
        self._cache: dict[Path, tuple] = {}
        self._lock = threading.Lock()
        self.skipped: dict[str, str] = {}             # a folder or file left out of the answers -> why

    def describe(self) -> str:
        return str(self.root)

    def close(self) -> None:
        pass

    # -- reading one folder -----------------------------------------------------------------------
    def _entry(self, folder: Path) -> tuple[SessionRow, list[CalibrationRecord]] | None:
        sig = _signature(folder)
        with self._lock:
            cached = self._cache.get(folder)
        if cached is not None and cached[0] == sig:
            return cached[1]
        try:
            with LocalSession.open(folder) as local:
                validate.check_file(local)
                meta = local.metadata()
                ident = identity.of(local, meta)
                holds, first, last = local.hold_summary()
        except StoreInputError as exc:
            with self._lock:
                self.skipped[str(folder)] = str(exc)
                self._cache[folder] = (sig, None)
            return None                            # not a readable session: not listed, but named
        with self._lock:
            self.skipped.pop(str(folder), None)
        row = SessionRow(ident.key, ident.name, ident.unit, ident.rig, ident.operator, ident.started, ident.status,
                         str(meta.get("status_reason") or ""), meta.get("verdict"), ident.ended, ident.planned, holds,
                         _utc(first), _utc(last), ident.simulated)
        value = (row, self._calibrations(folder, row))
        with self._lock:
            self._cache[folder] = (sig, value)
        return value

    def _calibrations(self, folder: Path, row: SessionRow) -> list[CalibrationRecord]:
        found = []
        own = folder / CALIBRATION_FILE
        if own.is_file() and row.status in identity.FINISHED:
            found.append(("", "rig", own))
        for path in sorted((folder / RESULTS).glob("calibration-*.json")):
            run = path.stem.removeprefix("calibration-")
            found.append((run, f"batch {run}", path))
        records = []
        for _, source, path in sorted(found, key=lambda f: f[0]):
            try:
                doc = read_calibration(path)
            except InputError as exc:
                with self._lock:
                    self.skipped[str(path)] = str(exc)
                continue
            except OSError as exc:
                with self._lock:
                    self.skipped[str(path)] = f"{path}: cannot be read ({exc.strerror})"
                continue
            with self._lock:
                self.skipped.pop(str(path), None)
            records.append(CalibrationRecord(row.name, row.key, row.started, row.rig, row.status, source, doc))
        return records

    def _all(self) -> list[tuple[Path, SessionRow, list[CalibrationRecord]]]:
        out = []
        folders = session_folders(self.root)
        with self._lock:
            present = {str(f) for f in folders}
            for gone in [k for k in self.skipped if not any(k == f or k.startswith(f + "/") for f in present)]:
                del self.skipped[gone]
        for folder in folders:
            entry = self._entry(folder)
            if entry is not None:
                out.append((folder, *entry))
        out.sort(key=lambda e: e[1].started)
        return out

    def _folder(self, ref: str) -> Path | None:
        for folder, row, _ in self._all():
            if ref in (row.key, row.name):
                return folder
        return None

    # -- sessions ---------------------------------------------------------------------------------
    def sessions(self, filters: Filters, limit: int = 100, offset: int = 0) -> tuple[list[SessionRow], int]:
        rows = [row for _, row, _ in reversed(self._all()) if filters.accepts(row)]
        return rows[offset:offset + limit], len(rows)

    def session(self, ref: str) -> SessionRow | None:
        rows = [row for _, row, _ in self._all() if ref in (row.key, row.name)]
        return rows[-1] if rows else None

    def running(self) -> list[SessionRow]:
        return [row for _, row, _ in reversed(self._all()) if row.status == "running"]

    def _local(self, key: str) -> LocalSession:
        folder = self._folder(key)
        if folder is None:
            raise StoreInputError(f"{self.root}: no session {key!r}")
        return LocalSession.open(folder)

    def metadata(self, key: str) -> dict:
        with self._local(key) as local:
            return local.metadata()

    def hold_means(self, key: str) -> list[dict]:
        with self._local(key) as local:
            return sessiondata.group_hold_means(local.hold_mean_rows())

    def events(self, key: str) -> list[dict]:
        with self._local(key) as local:
            return [{"t": t, "kind": k, "message": m, "written_utc": w} for _, t, k, m, w in local.events()]

    def artifacts(self, key: str) -> list[tuple[str, str]]:
        with self._local(key) as local:
            return [(name, media) for name, media, _ in local.artifacts()]

    def artifact(self, key: str, name: str) -> tuple[str, bytes] | None:
        with self._local(key) as local:
            found = [(media, data) for n, media, data in local.artifacts() if n == name]
        return found[0] if found else None

    def calibration_text(self, key: str, source: str) -> str | None:
        """The calibration file of one source ("rig", "batch <run>") of a session, as it lies in its folder."""
        folder = self._folder(key)
        if folder is None:
            return None
        run = source[len(BATCH_PREFIX):] if source.startswith(BATCH_PREFIX) else None
        if run is not None and not SAFE_RUN.match(run):
            return None
        path = folder / CALIBRATION_FILE if source == RIG_SOURCE else folder / RESULTS / f"calibration-{run}.json"
        try:
            return path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            return None

    def session_file(self, key: str) -> bytes:
        """The session's file (`session.sqlite`): a snapshot of what is committed, also while it is recorded."""
        with self._local(key) as local:
            return sessiondata.copy_of(local.connection)

    # -- across sessions --------------------------------------------------------------------------
    def calibrations(self, unit: str | None = None, key: str | None = None) -> list[CalibrationRecord]:
        """Every calibration (the rig's own first, then batch runs in their order) of the unit's or the session's
        sessions, oldest session first."""
        out = []
        for _, row, records in self._all():
            if (unit is not None and row.unit == unit) or (key is not None and row.key == key):
                out.extend(records)
        return out

    def units(self) -> list[dict]:
        units: dict[str, dict] = {}
        for _, row, records in self._all():
            u = units.setdefault(row.unit, {"serial": row.unit, "board": None, "sessions": 0, "calibrations": 0,
                                            "last_utc": None})
            u["sessions"] += 1
            if records:
                u["calibrations"] += 1
                u["last_utc"] = row.started
        return [units[k] for k in sorted(units)]

    def names(self) -> dict[str, list[str]]:
        rows = [row for _, row, _ in self._all()]
        return {"units": sorted({r.unit for r in rows}), "rigs": sorted({r.rig for r in rows})}

    def pass_fail(self, filters: Filters) -> list[tuple]:
        counts = Counter((row.started.astimezone(timezone.utc).date(), row.rig, row.status)
                         for _, row, _ in self._all() if filters.accepts(row))
        return [(*k, n) for k, n in sorted(counts.items())]

    # -- batch ------------------------------------------------------------------------------------
    def select_keys(self, filters: Filters) -> list[str]:
        return [row.key for _, row, _ in self._all() if filters.accepts(row)]

    def session_data(self, key: str) -> SessionData:
        with self._local(key) as local:
            return sessiondata.from_sqlite(local.connection, local.metadata(), str(local.folder / SESSION_FILE))

    def save_result(self, key: str, kind: str, run: str, ok: bool, document: str,
                    calibration: str | None = None, digest: str | None = None) -> None:
        folder = self._folder(key)
        if folder is None:
            raise StoreInputError(f"{self.root}: no session {key!r}")
        out = folder / RESULTS
        out.mkdir(exist_ok=True)
        write_text_atomic(out / f"{kind}-{run}.json", json.dumps({"ok": ok, "document": json.loads(document)},
                                                                 indent=1) + "\n")
        if calibration is not None:
            write_text_atomic(out / f"calibration-{run}.json", calibration)

    def results(self, key: str) -> list[dict]:
        folder = self._folder(key)
        out = []
        for path in sorted((folder / RESULTS).glob("*-*.json")) if folder else []:
            kind, _, run = path.stem.partition("-")
            if kind == "calibration":
                continue
            try:
                doc = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError):           # a result file damaged on disk: as if the run had not written it
                continue
            out.append({"kind": kind, "run": run, "ok": doc.get("ok"), "document": doc.get("document"),
                        "created_utc": datetime.fromtimestamp(path.stat().st_mtime, timezone.utc)})
        return out


def _signature(folder: Path) -> tuple:
    sig = []
    for name in (SESSION_FILE, SESSION_FILE + "-wal", CALIBRATION_FILE, RESULTS):
        try:
            st = (folder / name).stat()
            sig.append((st.st_mtime_ns, st.st_size))
        except OSError:
            sig.append(None)
    return tuple(sig)


def _utc(text: str | None) -> datetime | None:
    if not text:
        return None
    try:
        return identity.parse_utc(text)
    except ValueError:
        return None
