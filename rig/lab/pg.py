"""Connecting to the central PostgreSQL store (psycopg 3) and saying plainly what went wrong.

Connections time out rather than hang (connect, TCP user timeout, statement timeout), so a rig whose
network goes away finds out in seconds and keeps recording locally. A refusal that waiting cannot mend (a
wrong password, an unknown role or database, a TLS requirement not met, a privilege the role lacks) is told
apart from a server that is away (`StoreDenied` against `StoreUnavailable`), so that nothing retries it.

Credentials come from libpq's own files, never from the URL: the password file (`~/.pgpass`, `PGPASSFILE`)
and the service file (`pg_service.conf`, `postgresql://?service=NAME`). A URL carrying a password is refused:
it would be printed in the process list, kept in shell histories and, from a rig's configuration, in every
session's metadata.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from urllib.parse import parse_qs, urlsplit

import psycopg

from rig.lab.errors import (
    SchemaMismatch,
    StoreDenied,
    StoreError,
    StoreInputError,
    StoreReadOnly,
    StoreUnavailable,
    redact,
)
from rig.lab.pg_schema import ensure_schema

CONNECT_TIMEOUT_S = 5
TCP_USER_TIMEOUT_MS = 10_000
STATEMENT_TIMEOUT_MS = 60_000

# libpq's words for a refusal that no retry will change (it gives connection failures no SQLSTATE)
PERMANENT_REFUSALS = ("authentication failed", "no password supplied", "password is required", "does not exist",
                      "pg_hba.conf", "not permitted to log in", "permission denied", "server does not support ssl",
                      "certificate", "sslmode", "channel binding", "invalid connection option",
                      "invalid integer value", "invalid uri", "invalid percent-encoded")


def check_url(url: str) -> None:
    """Refuse a store URL that carries a password (see the module's doc)."""
    try:
        parts = urlsplit(url)
        has_password = parts.password is not None or "password" in parse_qs(parts.query)
    except ValueError:
        raise StoreInputError(f"{redact(url)}: not a usable database URL") from None
    if has_password:
        raise StoreInputError(f"{redact(url)}: a store URL must not carry a password (it would be kept in logs, "
                              "the process list and every session's configuration); put it in the password file "
                              "(~/.pgpass or $PGPASSFILE) or name a service of pg_service.conf "
                              "(postgresql://?service=NAME): docs/guides/lab-setup.md")


def connect(url: str, *, read_only: bool = False, create: bool = True,
            application: str = "rig") -> psycopg.Connection:
    """An autocommit connection (transactions are explicit) with the lab schema checked."""
    check_url(url)
    try:
        conn = psycopg.connect(url, autocommit=True, connect_timeout=CONNECT_TIMEOUT_S, application_name=application,
                               tcp_user_timeout=TCP_USER_TIMEOUT_MS,
                               options=f"-c statement_timeout={STATEMENT_TIMEOUT_MS}")
    except psycopg.ProgrammingError as exc:          # a malformed URL or option
        raise StoreInputError(f"{redact(url)}: not a usable database URL ({_first_line(exc)})") from None
    except psycopg.Error as exc:
        raise store_error(exc, url) from None
    try:
        if read_only:
            conn.read_only = True
        with translated(url):
            ensure_schema(conn, url, create=create and not read_only)
    except BaseException:
        conn.close()
        raise
    return conn


@contextlib.contextmanager
def translated(url: str) -> Iterator[None]:
    """psycopg's errors as the lab's, naming the store."""
    try:
        yield
    except (StoreError, SchemaMismatch):
        raise
    except psycopg.Error as exc:
        raise store_error(exc, url) from None


def store_error(exc: psycopg.Error, url: str) -> StoreError:
    where = redact(url)
    text = _first_line(exc)
    if isinstance(exc, psycopg.errors.InsufficientPrivilege):
        return StoreDenied(f"{where}: the database role may not do this ({text}); the lab's roles are in "
                           "docs/guides/lab-setup.md (`rig lab roles --sql`)")
    if isinstance(exc, psycopg.errors.ReadOnlySqlTransaction):
        return StoreReadOnly(f"{where}: the database refuses writes ({text})")
    if isinstance(exc, (psycopg.errors.UndefinedTable, psycopg.errors.UndefinedColumn)):
        return SchemaMismatch(f"{where}: the lab tables are not the layout this rig writes ({text})")
    if isinstance(exc, psycopg.errors.InvalidCatalogName):
        return StoreError(f"{where}: {text} (create it first: createdb)")
    if isinstance(exc, psycopg.OperationalError) and exc.sqlstate is None and permanent(text):
        return StoreDenied(f"{where}: the database refuses this rig ({text}); waiting will not help: fix the "
                           "credentials (~/.pgpass, pg_service.conf), the role or the URL")
    if isinstance(exc, (psycopg.OperationalError, psycopg.InterfaceError)):
        return StoreUnavailable(f"{where}: the database cannot be reached ({text})")
    return StoreError(f"{where}: {type(exc).__name__}: {text}")


def permanent(message: str) -> bool:
    """Whether libpq's connection failure `message` is one that no retry will change."""
    lowered = message.lower()
    return any(words in lowered for words in PERMANENT_REFUSALS)


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return "; ".join(lines[:2]) if lines else type(exc).__name__
