"""Who may do what in the central store: the roles, their grants and the row-level security that makes them.

- `lab_rig`: a rig. It reads what a push needs (the lab schema's version, units, rigs, operators, every
  session's summary row: the check that one unit is not on two rigs at once reads them) and inserts its own
  sessions and their rows; it may refresh its own sessions' summary columns and nothing else. It cannot
  change or delete a row of another rig's, nor read another rig's samples. Which rig a login pushes for is a
  row of `rig_logins` (login -> rig name), kept by the administrator.
- `lab_reader`: the web page and the questions (`rig serve`, `units`, `history`, `compare-rigs`,
  `pass-fail`): SELECT on every lab table, nothing else.
- `lab_analyst`: `rig batch`: a reader that may also add results and re-calibrations.
- the administrator: owns the tables (creates them, migrates them: `rig lab migrate`), keeps `rig_logins`.

The SQL is idempotent: running it again, with more logins, changes only what is new.
"""

from __future__ import annotations

import re

from rig.lab.errors import StoreInputError
from rig.lab.pg import connect, translated
from rig.lab.pg_schema import DDL, LAB_SCHEMA_VERSION, TABLES

GROUPS = ("lab_rig", "lab_reader", "lab_analyst")
SUMMARY = """role         who                           may
lab_rig      each rig (one login per rig)  read the schema version, units, rigs, operators, sessions' summaries;
                                           insert its own rig's sessions and their rows; refresh its own
                                           sessions' summary; nothing of another rig's (rig_logins: login -> rig)
lab_reader   rig serve, the questions      read every lab table
lab_analyst  rig batch                     read; add results and re-calibrations
(owner)      the administrator             create and migrate the tables (rig lab migrate), keep rig_logins
`rig lab roles --sql` prints the SQL; docs/guides/lab-setup.md says how to set a lab up.
"""
LOGIN = re.compile(r"^[a-z_][a-z0-9_]{0,62}$")
# the tables a rig writes, each with how a row names its session
SESSION_ROWS = ("session_metadata", "segments", "samples", "hold_stats", "events", "calibrations", "artifacts")
RIG_INSERTS = ("rigs", "units", "operators", "sessions", *SESSION_ROWS)
RIG_READS = ("lab_schema", "rig_logins", "rigs", "units", "operators", "sessions", "session_metadata", "segments",
             "events")
SUMMARY_COLUMNS = ("status", "status_reason", "verdict", "ended_utc", "planned", "last_seen_utc", "pushed_utc",
                   "holds", "first_hold_utc", "last_hold_utc")
SEQUENCES = {"lab_rig": ("rigs_id_seq", "units_id_seq", "operators_id_seq", "sessions_id_seq",
                         "calibrations_id_seq", "artifacts_id_seq"),
             "lab_analyst": ("calibrations_id_seq", "results_id_seq")}

OWN_RIG = "(SELECT r.id FROM rigs r JOIN rig_logins l ON l.rig = r.name WHERE l.login = current_user)"
OWN_SESSIONS = f"(SELECT s.id FROM sessions s WHERE s.rig_id IN {OWN_RIG})"

LOGINS_DDL = """CREATE TABLE IF NOT EXISTS rig_logins (
    login name PRIMARY KEY,          -- a database login (a member of lab_rig)
    rig text NOT NULL                -- the rig whose sessions it pushes (rigs.name)
)"""


def access_sql() -> list[str]:
    """The group roles, grants and policies, for a database whose lab tables exist."""
    out = [_create_role(g) for g in GROUPS]
    out += ["GRANT lab_reader TO lab_analyst",
            "REVOKE CREATE ON SCHEMA public FROM PUBLIC",
            "GRANT USAGE ON SCHEMA public TO lab_rig, lab_reader",
            "DO $$ BEGIN EXECUTE format('REVOKE CONNECT, TEMPORARY ON DATABASE %I FROM PUBLIC', current_database());"
            " EXECUTE format('GRANT CONNECT ON DATABASE %I TO lab_rig, lab_reader', current_database()); END $$",
            LOGINS_DDL]
    tables = (*TABLES, "rig_logins")
    out.append(f"REVOKE ALL ON {', '.join(tables)} FROM PUBLIC, lab_rig, lab_reader, lab_analyst")
    out.append(f"GRANT SELECT ON {', '.join(tables)} TO lab_reader")
    out.append("GRANT INSERT ON results, calibrations TO lab_analyst")
    out.append(f"GRANT SELECT ON {', '.join(RIG_READS)} TO lab_rig")
    out.append(f"GRANT INSERT ON {', '.join(RIG_INSERTS)} TO lab_rig")
    out.append(f"GRANT UPDATE ({', '.join(SUMMARY_COLUMNS)}) ON sessions TO lab_rig")
    for group, sequences in SEQUENCES.items():
        out.append(f"GRANT USAGE ON SEQUENCE {', '.join(sequences)} TO {group}")
    out += _policies()
    return out


def _policies() -> list[str]:
    out = []

    def policy(table: str, name: str, command: str, role: str, using: str | None = None,
               check: str | None = None) -> None:
        out.append(f"DROP POLICY IF EXISTS {name} ON {table}")
        out.append(f"CREATE POLICY {name} ON {table} FOR {command} TO {role}"
                   + (f" USING ({using})" if using else "") + (f" WITH CHECK ({check})" if check else ""))

    for table in ("rigs", "sessions", *SESSION_ROWS):
        out.append(f"ALTER TABLE {table} ENABLE ROW LEVEL SECURITY")
        policy(table, "lab_read", "SELECT", "lab_reader", using="true")
    policy("rigs", "rig_read", "SELECT", "lab_rig", using="true")
    policy("rigs", "rig_insert", "INSERT", "lab_rig",
           check="name IN (SELECT l.rig FROM rig_logins l WHERE l.login = current_user)")
    policy("sessions", "rig_read", "SELECT", "lab_rig", using="true")
    policy("sessions", "rig_insert", "INSERT", "lab_rig", check=f"rig_id IN {OWN_RIG}")
    policy("sessions", "rig_update", "UPDATE", "lab_rig", using=f"rig_id IN {OWN_RIG}", check=f"rig_id IN {OWN_RIG}")
    for table in SESSION_ROWS:
        if table in RIG_READS:
            policy(table, "rig_read", "SELECT", "lab_rig", using=f"session_id IN {OWN_SESSIONS}")
        policy(table, "rig_insert", "INSERT", "lab_rig", check=f"session_id IN {OWN_SESSIONS}")
    policy("calibrations", "analyst_insert", "INSERT", "lab_analyst", check="true")
    return out


def login_sql(*, rigs: dict[str, str], readers: list[str] = (), analysts: list[str] = ()) -> list[str]:
    """Logins for rigs (rig name -> login), readers and analysts, without passwords (set them with psql's
    `\\password LOGIN`, which sends only a hash, or use client certificates)."""
    out = []
    for group, logins in (("lab_rig", list(rigs.values())), ("lab_reader", list(readers)),
                          ("lab_analyst", list(analysts))):
        for login in logins:
            check_login(login)
            out.append(_create_role(login, login=True))
            out.append(f"GRANT {group} TO {login}")
    for rig, login in rigs.items():
        out.append(f"INSERT INTO rig_logins (login, rig) VALUES ({_literal(login)}, {_literal(rig)}) "
                   "ON CONFLICT (login) DO UPDATE SET rig = EXCLUDED.rig")
    return out


def script(*, rigs: dict[str, str] | None = None, readers: list[str] = (), analysts: list[str] = (),
           schema: bool = True) -> str:
    """The whole SQL an administrator runs (psql -1 -f): the lab tables when `schema`, then the access rules
    and the logins."""
    parts = ["-- rig lab: tables, roles and access rules (docs/guides/lab-setup.md); run as the tables' owner"]
    if schema:
        parts.append("-- the lab tables (schema version %d), as `rig lab migrate` creates them" % LAB_SCHEMA_VERSION)
        parts += [s.strip().replace("CREATE TABLE ", "CREATE TABLE IF NOT EXISTS ", 1)
                  .replace("CREATE INDEX ", "CREATE INDEX IF NOT EXISTS ", 1) + ";" for s in DDL.split(";") if s.strip()]
        parts.append(f"INSERT INTO lab_schema (version) SELECT {LAB_SCHEMA_VERSION} WHERE NOT EXISTS "
                     "(SELECT FROM lab_schema);")
    parts.append("-- who may do what")
    parts += [s + ";" for s in access_sql()]
    logins = login_sql(rigs=rigs or {}, readers=list(readers), analysts=list(analysts))
    if logins:
        parts.append("-- logins (passwords: psql's \\password LOGIN; never in this file)")
        parts += [s + ";" for s in logins]
    return "\n".join(parts) + "\n"


def check_login(login: str) -> None:
    if not LOGIN.match(login):
        raise StoreInputError(f"login {login!r}: a database login here is lower-case letters, digits and _ "
                              "(at most 63, not starting with a digit)")


def parse_rig_logins(pairs: tuple[str, ...] | list[str]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        rig, sep, login = pair.partition("=")
        if not sep or not rig.strip() or not login.strip():
            raise StoreInputError(f"--rig {pair!r}: give RIG=LOGIN (the rig's name in the store = its login)")
        check_login(login.strip())
        out[rig.strip()] = login.strip()
    return out


def _create_role(name: str, login: bool = False) -> str:
    return (f"DO $$ BEGIN IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = {_literal(name)}) THEN "
            f"CREATE ROLE {name} {'LOGIN' if login else 'NOLOGIN'}; END IF; END $$")


def _literal(text: str) -> str:
    return "'" + str(text).replace("'", "''") + "'"


def migrate(url: str, *, rigs: dict[str, str] | None = None, readers: list[str] = (),
            analysts: list[str] = ()) -> None:
    """As the administrator: the lab tables made if missing, the access rules and logins applied, in one
    transaction."""
    conn = connect(url, create=True, application="rig-lab-migrate")
    try:
        with translated(url), conn.transaction():
            for statement in access_sql() + login_sql(rigs=rigs or {}, readers=list(readers),
                                                      analysts=list(analysts)):
                conn.execute(statement)
    finally:
        conn.close()
