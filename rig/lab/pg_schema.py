"""The central store's tables on PostgreSQL (lab schema version 1) and the check every connection makes.

The recorded rows (segments with their samples and hold statistics, metadata history, events, calibrations,
report files, batch results) are append-only and keyed by natural keys: a session by the UUID made from its
identity (`LocalSession.key`), a segment, metadata row or event by its id in the session file. Every insert
is `ON CONFLICT DO NOTHING`, so pushing twice, or again after a push cut off half-way, stores one copy.
`sessions` also carries a summary (status, holds, last activity) refreshed from those rows by every push, so
the web page lists ten thousand sessions without reading their metadata.
"""

from __future__ import annotations

import psycopg

from rig.lab.errors import NoLabTables, SchemaMismatch, StoreDenied, StoreReadOnly, redact

LAB_SCHEMA_VERSION = 1
SCHEMA_LOCK = 0x52494753          # advisory lock key while creating the tables ("RIGS")

TABLES = ("lab_schema", "rigs", "operators", "units", "sessions", "session_metadata", "segments", "samples",
          "hold_stats", "events", "calibrations", "artifacts", "results")

DDL = """
CREATE TABLE lab_schema (version integer NOT NULL, created_utc timestamptz NOT NULL DEFAULT now());
CREATE TABLE rigs (id serial PRIMARY KEY, name text NOT NULL UNIQUE, first_seen timestamptz NOT NULL DEFAULT now());
CREATE TABLE operators (id serial PRIMARY KEY, name text NOT NULL UNIQUE);
CREATE TABLE units (id serial PRIMARY KEY, serial text NOT NULL UNIQUE, board text,
                    first_seen timestamptz NOT NULL DEFAULT now());
CREATE TABLE sessions (
    id bigserial PRIMARY KEY,
    key uuid NOT NULL UNIQUE,
    name text NOT NULL,
    unit_id integer NOT NULL REFERENCES units(id),
    rig_id integer NOT NULL REFERENCES rigs(id),
    operator_id integer REFERENCES operators(id),
    host text,
    started_utc timestamptz NOT NULL,
    simulated boolean NOT NULL DEFAULT false,
    status text NOT NULL,
    status_reason text NOT NULL DEFAULT '',
    verdict text,
    ended_utc timestamptz,
    planned integer,
    holds integer NOT NULL DEFAULT 0,
    first_hold_utc timestamptz,
    last_hold_utc timestamptz,
    last_seen_utc timestamptz,
    pushed_utc timestamptz NOT NULL DEFAULT now()
);
CREATE INDEX sessions_started ON sessions (started_utc DESC, id DESC);
CREATE INDEX sessions_unit ON sessions (unit_id, started_utc);
CREATE INDEX sessions_rig ON sessions (rig_id, started_utc);
CREATE INDEX sessions_running ON sessions (status) WHERE status = 'running';
CREATE TABLE session_metadata (
    session_id bigint NOT NULL REFERENCES sessions(id),
    seq integer NOT NULL, key text NOT NULL, value text NOT NULL, written_utc timestamptz NOT NULL,
    PRIMARY KEY (session_id, seq));
CREATE TABLE segments (
    session_id bigint NOT NULL REFERENCES sessions(id),
    seq integer NOT NULL,
    phase text NOT NULL CHECK (phase IN ('hold', 'move')),
    step integer NOT NULL, attempt integer NOT NULL,
    t_start double precision NOT NULL, t_end double precision NOT NULL, n_rows integer NOT NULL,
    commanded_outer_deg double precision, commanded_inner_deg double precision,
    measured_outer_deg double precision, measured_inner_deg double precision,
    written_utc timestamptz NOT NULL,
    digest text NOT NULL,
    PRIMARY KEY (session_id, seq));
CREATE TABLE samples (
    session_id bigint NOT NULL, segment_seq integer NOT NULL, name text NOT NULL,
    dtype text NOT NULL, shape text NOT NULL, data bytea NOT NULL,
    PRIMARY KEY (session_id, segment_seq, name),
    FOREIGN KEY (session_id, segment_seq) REFERENCES segments (session_id, seq));
CREATE TABLE hold_stats (
    session_id bigint NOT NULL, segment_seq integer NOT NULL, channel text NOT NULL,
    mean double precision, std double precision, count integer NOT NULL,
    PRIMARY KEY (session_id, segment_seq, channel),
    FOREIGN KEY (session_id, segment_seq) REFERENCES segments (session_id, seq));
CREATE TABLE events (
    session_id bigint NOT NULL REFERENCES sessions(id),
    seq integer NOT NULL, t double precision, kind text NOT NULL, message text NOT NULL,
    written_utc timestamptz NOT NULL,
    PRIMARY KEY (session_id, seq));
CREATE TABLE calibrations (
    id bigserial PRIMARY KEY,
    session_id bigint NOT NULL REFERENCES sessions(id),
    source text NOT NULL, digest text NOT NULL, document text NOT NULL,
    created_utc timestamptz NOT NULL DEFAULT now(),
    UNIQUE (session_id, source, digest));
CREATE TABLE artifacts (
    id bigserial PRIMARY KEY,
    session_id bigint NOT NULL REFERENCES sessions(id),
    name text NOT NULL, media_type text NOT NULL, digest text NOT NULL, content bytea NOT NULL,
    UNIQUE (session_id, name, digest));
CREATE TABLE results (
    id bigserial PRIMARY KEY,
    session_id bigint NOT NULL REFERENCES sessions(id),
    kind text NOT NULL, run text NOT NULL, ok boolean NOT NULL, document text NOT NULL,
    created_utc timestamptz NOT NULL DEFAULT now(),
    UNIQUE (session_id, kind, run));
"""


def stored_version(conn: psycopg.Connection) -> int | None:
    """The lab schema version in the database; None when it has no lab tables at all."""
    with conn.transaction():
        exists = conn.execute("SELECT to_regclass('lab_schema') IS NOT NULL").fetchone()[0]
        if not exists:
            return None
        row = conn.execute("SELECT max(version) FROM lab_schema").fetchone()
    return int(row[0]) if row and row[0] is not None else 0


def ensure_schema(conn: psycopg.Connection, url: str, *, create: bool = True) -> None:
    """Check the lab tables are this rig's version; create them in an empty database when `create`.

    An older or newer schema is refused with what to do: a rig never changes tables other rigs write to.
    """
    version = stored_version(conn)
    if version is None:
        if not create:
            raise NoLabTables(f"{redact(url)}: the database has no lab tables yet (the first `rig push` "
                                 "creates them)")
        try:
            # a session lock taken before the transaction: the transaction then starts after any other rig's
            # creation committed, and sees its tables (a lock taken inside it could look at stale catalogs)
            conn.execute("SELECT pg_advisory_lock(%s)", (SCHEMA_LOCK,))
            try:
                with conn.transaction():
                    if not conn.execute("SELECT to_regclass('lab_schema') IS NOT NULL").fetchone()[0]:
                        for statement in DDL.split(";"):
                            if statement.strip():
                                conn.execute(statement)
                        conn.execute("INSERT INTO lab_schema (version) VALUES (%s)", (LAB_SCHEMA_VERSION,))
            except psycopg.errors.DuplicateTable:
                pass                                # made by another rig at the same moment: use theirs
            finally:
                conn.execute("SELECT pg_advisory_unlock(%s)", (SCHEMA_LOCK,))
        except psycopg.errors.InsufficientPrivilege as exc:
            raise StoreDenied(f"{redact(url)}: the database has no lab tables and this role may not create them "
                              f"({exc.diag.message_primary}); an administrator makes them: `rig lab migrate "
                              "--store URL` (docs/guides/lab-setup.md)") from None
        except psycopg.errors.ReadOnlySqlTransaction as exc:
            raise StoreReadOnly(f"{redact(url)}: cannot create the lab tables: the database is read-only for "
                                f"this user ({exc.diag.message_primary})") from None
        version = stored_version(conn)
    if version != LAB_SCHEMA_VERSION:
        side = "older" if version < LAB_SCHEMA_VERSION else "newer"
        advice = ("it was made by an older rig; have the lab's database upgraded (or point the rigs at a new "
                  "database)" if side == "older" else "update this rig's software to the version the lab runs")
        raise SchemaMismatch(f"{redact(url)}: the lab tables are schema version {version}, {side} than this rig's "
                             f"({LAB_SCHEMA_VERSION}); {advice}")
