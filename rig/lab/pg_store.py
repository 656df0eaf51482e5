"""The questions asked of the central PostgreSQL store (a pool of connections, read-only unless writing
batch results)."""

from __future__ import annotations

import uuid

from psycopg_pool import ConnectionPool, PoolTimeout

from rig.lab import sessiondata
from rig.lab.errors import NoLabTables, StoreInputError, StoreUnavailable, redact
from rig.lab.pg import CONNECT_TIMEOUT_S, STATEMENT_TIMEOUT_MS, TCP_USER_TIMEOUT_MS, connect, translated
from rig.lab.pg_schema import ensure_schema, stored_version
from rig.lab.records import CalibrationRecord, Filters, SessionRow, iso, load_document
from rig.session_data import SessionData

ROW = ("SELECT s.key::text, s.name, u.serial, r.name, coalesce(o.name, ''), s.started_utc, s.status, s.status_reason,"
       " s.verdict, s.ended_utc, s.planned, s.holds, s.first_hold_utc, s.last_hold_utc, s.simulated"
       " FROM sessions s JOIN units u ON u.id = s.unit_id JOIN rigs r ON r.id = s.rig_id"
       " LEFT JOIN operators o ON o.id = s.operator_id")
# each session's calibration per source (the rig's own, each batch run's): the latest stored of each
CALIBRATION_PER_SOURCE = ("SELECT DISTINCT ON (c.session_id, c.source) c.id, c.session_id, c.source, c.document "
                          "FROM calibrations c ORDER BY c.session_id, c.source, c.id DESC")


class PgStore:
    kind = "postgresql"

    def __init__(self, url: str, *, write: bool = False, max_connections: int = 8) -> None:
        self.url = url
        self.skipped: dict[str, str] = {}             # a stored record left out of the answers -> why
        try:
            connect(url, read_only=not write, create=write).close()    # reachable, and the schema is ours
            self._tables = True
        except NoLabTables:
            self._tables = False                                       # nothing pushed yet: an empty store
        options = f"-c statement_timeout={STATEMENT_TIMEOUT_MS}" + ("" if write else
                                                                    " -c default_transaction_read_only=on")
        self.pool = ConnectionPool(url, min_size=1, max_size=max_connections, open=True, timeout=CONNECT_TIMEOUT_S,
                                   kwargs={"autocommit": True, "options": options, "application_name": "rig-lab",
                                           "connect_timeout": CONNECT_TIMEOUT_S,
                                           "tcp_user_timeout": TCP_USER_TIMEOUT_MS},
                                   check=ConnectionPool.check_connection)

    def describe(self) -> str:
        return redact(self.url)

    def close(self) -> None:
        self.pool.close()

    def _all(self, sql: str, args=()) -> list[tuple]:
        try:
            with translated(self.url), self.pool.connection() as conn:
                if not self._tables:
                    if stored_version(conn) is None:
                        return []
                    ensure_schema(conn, self.url, create=False)
                    self._tables = True
                return conn.execute(sql, args).fetchall()
        except PoolTimeout:
            raise StoreUnavailable(f"{redact(self.url)}: the database cannot be reached (no connection within "
                                   f"{CONNECT_TIMEOUT_S} s)") from None

    # -- sessions ---------------------------------------------------------------------------------
    def sessions(self, filters: Filters, limit: int = 100, offset: int = 0) -> tuple[list[SessionRow], int]:
        where, args = _where(filters)
        rows = self._all(f"{ROW}{where} ORDER BY s.started_utc DESC, s.id DESC LIMIT %s OFFSET %s",
                         (*args, limit, offset))
        total = self._all("SELECT count(*) FROM sessions s JOIN units u ON u.id = s.unit_id JOIN rigs r ON "
                          f"r.id = s.rig_id LEFT JOIN operators o ON o.id = s.operator_id{where}", args)
        return [SessionRow(*r) for r in rows], int(total[0][0]) if total else 0

    def session(self, ref: str) -> SessionRow | None:
        column = "s.key" if _is_uuid(ref) else "s.name"
        rows = self._all(f"{ROW} WHERE {column} = %s ORDER BY s.started_utc DESC LIMIT 1", (ref,))
        return SessionRow(*rows[0]) if rows else None

    def running(self) -> list[SessionRow]:
        return [SessionRow(*r) for r in self._all(f"{ROW} WHERE s.status = 'running' ORDER BY s.started_utc DESC")]

    def metadata(self, key: str) -> dict:
        rows = self._all("SELECT DISTINCT ON (m.key) m.key, m.value FROM session_metadata m JOIN sessions s ON "
                         "s.id = m.session_id WHERE s.key = %s ORDER BY m.key, m.seq DESC", (key,))
        return {k: sessiondata.loads(v) for k, v in rows}

    def hold_means(self, key: str) -> list[dict]:
        rows = self._all("SELECT g.seq, g.step, g.attempt, g.written_utc, h.channel, h.mean FROM segments g "
                         "JOIN sessions s ON s.id = g.session_id LEFT JOIN hold_stats h ON h.session_id = g.session_id"
                         " AND h.segment_seq = g.seq WHERE s.key = %s AND g.phase = 'hold' ORDER BY g.seq", (key,))
        return sessiondata.group_hold_means(rows)

    def events(self, key: str) -> list[dict]:
        rows = self._all("SELECT e.t, e.kind, e.message, e.written_utc FROM events e JOIN sessions s ON "
                         "s.id = e.session_id WHERE s.key = %s ORDER BY e.seq", (key,))
        return [{"t": t, "kind": k, "message": m, "written_utc": w} for t, k, m, w in rows]

    def artifacts(self, key: str) -> list[tuple[str, str]]:
        return [tuple(r) for r in self._all(
            "SELECT DISTINCT ON (a.name) a.name, a.media_type FROM artifacts a JOIN sessions s ON s.id = a.session_id"
            " WHERE s.key = %s ORDER BY a.name, a.id DESC", (key,))]

    def artifact(self, key: str, name: str) -> tuple[str, bytes] | None:
        rows = self._all("SELECT a.media_type, a.content FROM artifacts a JOIN sessions s ON s.id = a.session_id "
                         "WHERE s.key = %s AND a.name = %s ORDER BY a.id DESC LIMIT 1", (key, name))
        return (rows[0][0], bytes(rows[0][1])) if rows else None

    def calibration_text(self, key: str, source: str) -> str | None:
        """The calibration file of one source ("rig", "batch <run>") of a session, as it was stored."""
        rows = self._all("SELECT c.document FROM calibrations c JOIN sessions s ON s.id = c.session_id WHERE s.key = %s"
                         " AND c.source = %s ORDER BY c.id DESC LIMIT 1", (key, source))
        return rows[0][0] if rows else None

    def session_file(self, key: str) -> bytes:
        """The session's file (`session.sqlite`) rebuilt from its stored rows (`sessiondata.session_file`)."""
        join = "JOIN sessions s ON s.id = x.session_id WHERE s.key = %s"
        metadata = self._all(f"SELECT x.seq, x.key, x.value, x.written_utc FROM session_metadata x {join} "
                             "ORDER BY x.seq", (key,))
        segments = self._all("SELECT x.seq, x.phase, x.step, x.attempt, x.t_start, x.t_end, x.n_rows, "
                             "x.commanded_outer_deg, x.commanded_inner_deg, x.measured_outer_deg, "
                             f"x.measured_inner_deg, x.written_utc FROM segments x {join} ORDER BY x.seq", (key,))
        arrays = self._all(f"SELECT x.segment_seq, x.name, x.dtype, x.shape, x.data FROM samples x {join}", (key,))
        stats = self._all(f"SELECT x.segment_seq, x.channel, x.mean, x.std, x.count FROM hold_stats x {join}", (key,))
        events = self._all(f"SELECT x.seq, x.t, x.kind, x.message, x.written_utc FROM events x {join} ORDER BY x.seq",
                           (key,))
        return sessiondata.session_file([(*r[:3], iso(r[3])) for r in metadata],
                                        [(*r[:11], iso(r[11])) for r in segments], arrays, stats,
                                        [(*r[:4], iso(r[4])) for r in events])

    # -- across sessions --------------------------------------------------------------------------
    def calibrations(self, unit: str | None = None, key: str | None = None) -> list[CalibrationRecord]:
        """Every calibration (the rig's own first, then batch runs in their order) of the unit's or the session's
        sessions, oldest session first."""
        cond, args = ("u.serial = %s", (unit,)) if unit is not None else ("s.key = %s", (key,))
        rows = self._all(f"SELECT s.name, s.key::text, s.started_utc, r.name, s.status, c.source, c.document "
                         f"FROM sessions s JOIN units u ON u.id = s.unit_id JOIN rigs r ON r.id = s.rig_id "
                         f"JOIN ({CALIBRATION_PER_SOURCE}) c ON c.session_id = s.id WHERE {cond} "
                         "ORDER BY s.started_utc, s.id, c.source <> 'rig', c.id", args)
        records = []
        for n, k, st, rig, status, src, doc in rows:
            where = f"{redact(self.url)} session {n} ({src} calibration)"
            try:
                records.append(CalibrationRecord(n, k, st, rig, status, src, load_document(doc, where)))
            except StoreInputError as exc:          # not a JSON document: left out of the answer, named
                self.skipped[where] = str(exc)
        return records

    def units(self) -> list[dict]:
        rows = self._all("SELECT u.serial, u.board, count(s.id), count(c.session_id), max(s.started_utc) FILTER "
                         "(WHERE c.session_id IS NOT NULL) FROM units u LEFT JOIN sessions s ON s.unit_id = u.id "
                         "LEFT JOIN (SELECT DISTINCT session_id FROM calibrations) c ON c.session_id = s.id "
                         "GROUP BY u.id ORDER BY u.serial")
        return [{"serial": serial, "board": board, "sessions": int(n), "calibrations": int(c), "last_utc": last}
                for serial, board, n, c, last in rows]

    def names(self) -> dict[str, list[str]]:
        return {"units": [r[0] for r in self._all("SELECT serial FROM units ORDER BY serial")],
                "rigs": [r[0] for r in self._all("SELECT name FROM rigs ORDER BY name")]}

    def pass_fail(self, filters: Filters) -> list[tuple]:
        where, args = _where(filters)
        return self._all("SELECT (s.started_utc AT TIME ZONE 'UTC')::date AS day, r.name, s.status, count(*) FROM "
                         "sessions s JOIN units u ON u.id = s.unit_id JOIN rigs r ON r.id = s.rig_id LEFT JOIN "
                         f"operators o ON o.id = s.operator_id{where} GROUP BY 1, 2, 3 ORDER BY 1, 2, 3", args)

    # -- batch ------------------------------------------------------------------------------------
    def select_keys(self, filters: Filters) -> list[str]:
        where, args = _where(filters)
        return [r[0] for r in self._all(f"{ROW}{where} ORDER BY s.started_utc, s.id", args)]

    def session_data(self, key: str) -> SessionData:
        rows = self._all("SELECT g.seq, g.phase, g.step, g.attempt, g.t_start, g.t_end, g.n_rows, g.written_utc "
                         "FROM segments g JOIN sessions s ON s.id = g.session_id WHERE s.key = %s ORDER BY g.seq",
                         (key,))
        arrays = self._all("SELECT a.segment_seq, a.name, a.dtype, a.shape, a.data FROM samples a JOIN sessions s "
                           "ON s.id = a.session_id WHERE s.key = %s", (key,))
        events = self._all("SELECT e.seq, e.t, e.kind, e.message, e.written_utc FROM events e JOIN sessions s ON "
                           "s.id = e.session_id WHERE s.key = %s ORDER BY e.seq", (key,))
        return sessiondata.from_rows(rows, arrays, events, self.metadata(key), f"{redact(self.url)} session {key}")

    def save_result(self, key: str, kind: str, run: str, ok: bool, document: str,
                    calibration: str | None = None, digest: str | None = None) -> None:
        with translated(self.url), self.pool.connection() as conn, conn.transaction():
            sid = conn.execute("SELECT id FROM sessions WHERE key = %s", (key,)).fetchone()[0]
            conn.execute("INSERT INTO results (session_id, kind, run, ok, document) VALUES (%s, %s, %s, %s, %s) "
                         "ON CONFLICT DO NOTHING", (sid, kind, run, ok, document))
            if calibration is not None:
                conn.execute("INSERT INTO calibrations (session_id, source, digest, document) VALUES (%s, %s, %s, %s)"
                             " ON CONFLICT DO NOTHING", (sid, f"batch {run}", digest, calibration))

    def results(self, key: str) -> list[dict]:
        rows = self._all("SELECT r.kind, r.run, r.ok, r.document, r.created_utc FROM results r JOIN sessions s ON "
                         "s.id = r.session_id WHERE s.key = %s ORDER BY r.id", (key,))
        return [{"kind": k, "run": run, "ok": ok, "document": sessiondata.loads(doc), "created_utc": c}
                for k, run, ok, doc, c in rows]


def _where(f: Filters) -> tuple[str, tuple]:
    cond, args = [], []
    for column, value in (("u.serial", f.unit), ("r.name", f.rig), ("o.name", f.operator)):
        if value is not None:
            cond.append(f"{column} = %s")
            args.append(value)
    if f.status:
        cond.append("s.status = ANY(%s)")
        args.append(list(f.status))
    lo, hi = f.bounds()
    if lo is not None:
        cond.append("s.started_utc >= %s")
        args.append(lo)
    if hi is not None:
        cond.append("s.started_utc < %s")
        args.append(hi)
    if f.session is not None:
        cond.append("s.key = %s" if _is_uuid(f.session) else "s.name = %s")
        args.append(f.session)
    return (" WHERE " + " AND ".join(cond) if cond else ""), tuple(args)


def _is_uuid(text: str) -> bool:
    try:
        uuid.UUID(str(text))
    except ValueError:
        return False
    return True
