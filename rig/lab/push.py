"""Pushing a local session to the central store: what it lacks, once, in small transactions.

A session is registered under its natural key (`LocalSession.key`) in a transaction that holds an advisory
lock on its unit serial, so two rigs claiming one unit at the same moment are told apart: the second is
refused, naming the first. Before anything is written the segments the store already has are compared with
the local ones by digest; a session that differs from the stored one under the same key is refused whole.
Then each hold goes with the move that led to it in one transaction (as in the session file), metadata and
events after them, and the calibration and report files once the session is finished.

Nothing is written before it is checked against its format (`rig.lab.validate`): the first push of a
session checks the whole folder as it stands (the file's integrity and layout, every record, and the
calibration and report files of a finished session), so a damaged folder is refused whole; a live mirror's
later pushes check each new record, and the files once the session is finished, before they go. Every insert is
`ON CONFLICT DO NOTHING`: a push cut off anywhere is finished by the next one, with one copy of every row.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from datetime import datetime, timezone

import psycopg

from rig.lab import identity, validate
from rig.lab.errors import PushRefused, UnitClaimed, redact
from rig.lab.local import LocalSession, Segment
from rig.lab.pg import translated

BATCH_BYTES = 4 << 20          # a transaction carries at most about this much sample data (holds stay whole)
STALE_S = 600                  # a "running" session silent for longer no longer claims its unit


@dataclass
class PushResult:
    session: str                   # the session's key
    name: str
    holds: int = 0                 # new hold segments stored by this push
    moves: int = 0
    metadata: int = 0
    events: int = 0
    files: int = 0                 # calibration and report files
    status: str = ""

    @property
    def changed(self) -> bool:
        return bool(self.holds or self.moves or self.metadata or self.events or self.files)

    def line(self) -> str:
        if not self.changed:
            return f"{self.name}: up to date ({self.status})"
        parts = [f"{n} {what}" for n, what in ((self.holds, "holds"), (self.moves, "moves"),
                                                (self.metadata, "metadata rows"), (self.events, "events"),
                                                (self.files, "files")) if n]
        return f"{self.name}: pushed {', '.join(parts)} ({self.status})"


class Pusher:
    """Pushes one local session into one connection; keeps what it has pushed so a live mirror polls cheaply."""

    def __init__(self, local: LocalSession, conn: psycopg.Connection, url: str, *, rig: str | None = None) -> None:
        self.local, self.conn, self.url, self.rig = local, conn, url, rig
        self.session_id: int | None = None
        self.done = {"metadata": 0, "segment": 0, "event": 0}
        self.files_pushed: set[str] = set()
        self.checked_segment = 0              # segments up to this seq were checked by the first push

    def push(self) -> PushResult:
        with translated(self.url):
            return self._push()

    def _push(self) -> PushResult:
        first = self.session_id is None
        if first:
            validate.check_file(self.local)
        meta = self.local.metadata()
        if first:
            self.checked_segment = validate.check_records(self.local, meta, files=meta.get("status") in
                                                          identity.FINISHED)
        ident = identity.of(self.local, meta, rig=self.rig)
        result = PushResult(ident.key, ident.name, status=meta.get("status", ""))
        if first:
            self.session_id = self._register(ident)
            self._check_stored()
        result.metadata = self._push_metadata()
        moves, holds = self._push_segments(meta)
        result.moves, result.holds = moves, holds
        result.events = self._push_events()
        if meta.get("status") in identity.FINISHED:
            result.files = self._push_files()
        self._refresh(ident, meta)
        return result

    # -- registering ------------------------------------------------------------------------------
    def _register(self, ident: identity.Identity) -> int:
        with self.conn.transaction():
            self.conn.execute("SELECT pg_advisory_xact_lock(hashtext(%s))", (ident.unit,))
            row = self.conn.execute("SELECT s.id, r.name FROM sessions s JOIN rigs r ON r.id = s.rig_id "
                                    "WHERE s.key = %s", (ident.key,)).fetchone()
            if row is not None:
                if self.rig is not None and row[1] != ident.rig:
                    raise PushRefused(f"{self.local.folder}: this session is stored as recorded on rig "
                                      f"{row[1]!r}; it cannot be pushed again as rig {ident.rig!r}")
                return int(row[0])
            unit_id = _id(self.conn, "units", "serial", ident.unit, board=ident.board)
            rig_id = _id(self.conn, "rigs", "name", ident.rig)
            operator_id = _id(self.conn, "operators", "name", ident.operator) if ident.operator else None
            self._refuse_claimed(ident, unit_id, rig_id)
            return int(self.conn.execute(
                "INSERT INTO sessions (key, name, unit_id, rig_id, operator_id, host, started_utc, simulated, status,"
                " planned, last_seen_utc) VALUES (%s, %s, %s, %s, %s, %s, %s, %s, %s, %s, %s) RETURNING id",
                (ident.key, ident.name, unit_id, rig_id, operator_id, ident.host, ident.started, ident.simulated,
                 ident.status, ident.planned, ident.last_activity)).fetchone()[0])

    def _refuse_claimed(self, ident: identity.Identity, unit_id: int, rig_id: int) -> None:
        """Another rig's session of the same unit overlapping this one in time: refused, that one named."""
        end = ident.ended or (ident.last_activity if _stale(ident.last_activity) else None)
        row = self.conn.execute(
            "SELECT s.name, r.name, s.started_utc, s.status FROM sessions s JOIN rigs r ON r.id = s.rig_id "
            "WHERE s.unit_id = %s AND s.rig_id <> %s AND s.started_utc < coalesce(%s::timestamptz, 'infinity') "
            "AND %s < coalesce(s.ended_utc, CASE WHEN s.status = 'running' AND s.last_seen_utc > now() - "
            "make_interval(secs => %s) THEN 'infinity'::timestamptz ELSE s.last_seen_utc END) "
            "ORDER BY s.started_utc LIMIT 1", (unit_id, rig_id, end, ident.started, STALE_S)).fetchone()
        if row is not None:
            other, other_rig, started, status = row
            raise UnitClaimed(f"{self.local.folder}: unit {ident.unit!r} is claimed by rig {other_rig!r} (session "
                              f"{other!r}, {status}, started {started:%Y-%m-%d %H:%M:%S} UTC) at the same time as "
                              f"this session on rig {ident.rig!r}; one unit cannot be on two rigs at once: not "
                              "pushed (it stays recorded locally)")

    def _check_stored(self) -> None:
        """The segments already stored must be the local ones: else this is another recording, refused."""
        stored = dict(self.conn.execute("SELECT seq, digest FROM segments WHERE session_id = %s",
                                        (self.session_id,)).fetchall())
        if not stored:
            return
        local = {s.seq: s for s in self.local.segments(0, max(stored))}
        for seq, digest in sorted(stored.items()):
            mine = local.get(seq)
            if mine is None or mine.digest != digest:
                here = mine.describe() if mine else "nothing"
                raise PushRefused(f"{self.local.folder}: conflicts with the session stored under the same identity "
                                  f"in {redact(self.url)}: segment {seq} differs (here: {here}); two different "
                                  "recordings claim to be one session (a copied folder resumed twice?): not pushed")
        self.done["segment"] = max(stored)
        self.done["metadata"] = self._max("session_metadata")
        self.done["event"] = self._max("events")

    def _max(self, table: str) -> int:
        return int(self.conn.execute(f"SELECT coalesce(max(seq), 0) FROM {table} WHERE session_id = %s",
                                     (self.session_id,)).fetchone()[0])

    # -- rows -------------------------------------------------------------------------------------
    def _push_metadata(self) -> int:
        rows = self.local.metadata_rows(self.done["metadata"])
        if not rows:
            return 0
        validate.check_metadata(self.local, rows)
        with self.conn.transaction():
            with self.conn.cursor() as cur:
                cur.executemany("INSERT INTO session_metadata (session_id, seq, key, value, written_utc) "
                                "VALUES (%s, %s, %s, %s, %s) ON CONFLICT DO NOTHING",
                                [(self.session_id, *row) for row in rows])
        self.done["metadata"] = rows[-1][0]
        return len(rows)

    def _push_segments(self, meta: dict) -> tuple[int, int]:
        segments = self.local.segments(self.done["segment"])
        for seg in segments:
            if seg.seq > self.checked_segment:
                validate.check_segment(self.local, seg, meta)
        moves = holds = 0
        batch: list[Segment] = []
        size = 0
        for seg in segments:
            batch.append(seg)
            size += sum(len(a[3]) for a in seg.arrays)
            if seg.phase == "hold" and size >= BATCH_BYTES:
                self._insert_segments(batch)
                batch, size = [], 0
        if batch:
            self._insert_segments(batch)
        for seg in segments:
            holds += seg.phase == "hold"
            moves += seg.phase == "move"
        return moves, holds

    def _insert_segments(self, batch: list[Segment]) -> None:
        sid = self.session_id
        with self.conn.transaction(), self.conn.cursor() as cur:
            cur.executemany(
                "INSERT INTO segments (session_id, seq, phase, step, attempt, t_start, t_end, n_rows,"
                " commanded_outer_deg, commanded_inner_deg, measured_outer_deg, measured_inner_deg, written_utc,"
                " digest) VALUES (%s, %s, %s, %s, %s, %s, %s, %s, %s, %s, %s, %s, %s, %s) ON CONFLICT DO NOTHING",
                [(sid, s.seq, s.phase, s.step, s.attempt, s.t_start, s.t_end, s.n_rows, *s.angles, s.written_utc,
                  s.digest) for s in batch])
            cur.executemany("INSERT INTO samples (session_id, segment_seq, name, dtype, shape, data) "
                            "VALUES (%s, %s, %s, %s, %s, %s) ON CONFLICT DO NOTHING",
                            [(sid, s.seq, *a) for s in batch for a in s.arrays])
            stats = [(sid, s.seq, *row) for s in batch for row in s.stats]
            if stats:
                cur.executemany("INSERT INTO hold_stats (session_id, segment_seq, channel, mean, std, count) "
                                "VALUES (%s, %s, %s, %s, %s, %s) ON CONFLICT DO NOTHING", stats)
        self.done["segment"] = batch[-1].seq

    def _push_events(self) -> int:
        rows = self.local.events(self.done["event"])
        if not rows:
            return 0
        validate.check_events(self.local, rows)
        with self.conn.transaction(), self.conn.cursor() as cur:
            cur.executemany("INSERT INTO events (session_id, seq, t, kind, message, written_utc) "
                            "VALUES (%s, %s, %s, %s, %s, %s) ON CONFLICT DO NOTHING",
                            [(self.session_id, *row) for row in rows])
        self.done["event"] = rows[-1][0]
        return len(rows)

    def _push_files(self) -> int:
        validate.check_files(self.local)
        added = 0
        calibration = self.local.calibration_text()
        if calibration is not None and _digest(calibration.encode()) not in self.files_pushed:
            digest = _digest(calibration.encode())
            with self.conn.transaction():
                cur = self.conn.execute("INSERT INTO calibrations (session_id, source, digest, document) VALUES "
                                        "(%s, 'rig', %s, %s) ON CONFLICT DO NOTHING", (self.session_id, digest,
                                                                                       calibration))
                added += cur.rowcount
            self.files_pushed.add(digest)
        for name, media, content in self.local.artifacts():
            digest = _digest(content)
            if digest in self.files_pushed:
                continue
            with self.conn.transaction():
                cur = self.conn.execute("INSERT INTO artifacts (session_id, name, media_type, digest, content) "
                                        "VALUES (%s, %s, %s, %s, %s) ON CONFLICT DO NOTHING",
                                        (self.session_id, name, media, digest, content))
                added += cur.rowcount
            self.files_pushed.add(digest)
        return added

    def _refresh(self, ident: identity.Identity, meta: dict) -> None:
        """The session's summary row from what is now stored (one statement, its own transaction)."""
        self.conn.execute(
            "UPDATE sessions s SET status = %s, status_reason = %s, verdict = %s, ended_utc = %s, planned = %s,"
            " last_seen_utc = greatest(s.last_seen_utc, %s), pushed_utc = now(),"
            " holds = h.holds, first_hold_utc = h.first, last_hold_utc = h.last"
            " FROM (SELECT count(DISTINCT step) AS holds, min(written_utc) AS first, max(written_utc) AS last"
            "       FROM segments WHERE session_id = %s AND phase = 'hold') h WHERE s.id = %s",
            (ident.status, str(meta.get("status_reason") or ""), meta.get("verdict"), ident.ended, ident.planned,
             ident.last_activity, self.session_id, self.session_id))


def _id(conn: psycopg.Connection, table: str, column: str, value: str, **extra) -> int:
    """The id of a reference row (unit, rig, operator), inserted if new (concurrent rigs may race: no error)."""
    columns = [column, *extra]
    conn.execute(f"INSERT INTO {table} ({', '.join(columns)}) VALUES ({', '.join(['%s'] * len(columns))}) "
                 "ON CONFLICT DO NOTHING", (value, *extra.values()))
    return int(conn.execute(f"SELECT id FROM {table} WHERE {column} = %s", (value,)).fetchone()[0])


def _stale(when: datetime | None) -> bool:
    return when is not None and (datetime.now(timezone.utc) - when).total_seconds() > STALE_S


def _digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()
