"""Connecting to the central PostgreSQL store (psycopg 3) and saying plainly what went wrong.

Connections time out rather than hang (connect, TCP user timeout, statement timeout), so a rig whose
network goes away finds out in seconds and keeps recording locally.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import psycopg

from rig.lab.errors import SchemaMismatch, StoreError, StoreReadOnly, StoreUnavailable, redact
from rig.lab.pg_schema import ensure_schema

CONNECT_TIMEOUT_S = 5
TCP_USER_TIMEOUT_MS = 10_000
STATEMENT_TIMEOUT_MS = 60_000


def connect(url: str, *, read_only: bool = False, create: bool = True,
            application: str = "rig") -> psycopg.Connection:
    """An autocommit connection (transactions are explicit) with the lab schema checked."""
    try:
        conn = psycopg.connect(url, autocommit=True, connect_timeout=CONNECT_TIMEOUT_S, application_name=application,
                               tcp_user_timeout=TCP_USER_TIMEOUT_MS,
                               options=f"-c statement_timeout={STATEMENT_TIMEOUT_MS}")
    except psycopg.ProgrammingError as exc:          # a malformed URL or option
        raise StoreError(f"{redact(url)}: not a usable database URL ({_first_line(exc)})") from None
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
    if isinstance(exc, (psycopg.errors.ReadOnlySqlTransaction, psycopg.errors.InsufficientPrivilege)):
        return StoreReadOnly(f"{where}: the database refuses writes ({text})")
    if isinstance(exc, (psycopg.errors.UndefinedTable, psycopg.errors.UndefinedColumn)):
        return SchemaMismatch(f"{where}: the lab tables are not the layout this rig writes ({text})")
    if isinstance(exc, psycopg.errors.InvalidCatalogName):
        return StoreError(f"{where}: {text} (create it first: createdb)")
    if isinstance(exc, (psycopg.OperationalError, psycopg.InterfaceError)):
        return StoreUnavailable(f"{where}: the database cannot be reached ({text})")
    return StoreError(f"{where}: {type(exc).__name__}: {text}")


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return "; ".join(lines[:2]) if lines else type(exc).__name__
