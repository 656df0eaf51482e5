"""What can go wrong between a rig and the central store, each with the exit code it deserves.

The local session is never touched by any of these: the message always says where the data still is.
"""

from __future__ import annotations

from urllib.parse import urlsplit, urlunsplit

from rig.errors import Busy, InputError, RigError


class StoreError(RigError):
    """The central store cannot be used (a fault: exit 3)."""


class StoreUnavailable(StoreError):
    """The database refused the connection, or dropped it; worth trying again later."""


class StoreReadOnly(StoreError):
    """The database (or the user) accepts reads only."""


class SchemaMismatch(StoreError):
    """The database holds the lab's tables in another version than this rig writes."""


class NoLabTables(SchemaMismatch):
    """The database is reachable but nothing was ever pushed to it (a reader sees an empty store)."""


class StoreDenied(StoreError, InputError):
    """The database will not let these credentials in, or not do this (a wrong password, an unknown role or
    database, a TLS requirement not met, a privilege the role lacks): permanent, never retried; the
    credentials or the role are the user's to fix (exit 2)."""


class PushRefused(InputError):
    """A session that conflicts with the one stored under the same identity (exit 2)."""


class UnitClaimed(Busy):
    """Another rig is calibrating the same unit serial at the same time (exit 4)."""


class StoreInputError(InputError):
    """A store URL or folder, a filter or a name given by the user cannot be used."""


class CorruptInput(StoreInputError):
    """A file or record of a session breaks its published format (a truncated calibration.json, a damaged or
    foreign session.sqlite): refused whole, named with the reason; nothing of it enters the store (exit 2)."""


def redact(url: str) -> str:
    """The URL without its password, for messages (a password belongs in ~/.pgpass, not in a log)."""
    try:
        parts = urlsplit(url)
    except ValueError:
        return "<unparsable store URL>"
    if parts.password is None:
        return url
    netloc = parts.netloc.rsplit("@", 1)
    user = (parts.username or "") + ":***"
    return urlunsplit(parts._replace(netloc=f"{user}@{netloc[-1]}"))


def is_database_url(store: str) -> bool:
    return str(store).startswith(("postgresql://", "postgres://"))
