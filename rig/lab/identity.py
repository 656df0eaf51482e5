"""Who and what a session is, for the central store: its key, unit, rig, operator, times and status.

The rig a session ran on is, in order: the name given to `rig push --rig` (or the live mirror), the
metadata key `rig` (a name, or a table with `name`), `[store] rig` in the configuration snapshot, else the
host name of the PC that ran it (one PC, one turntable is the usual lab bench).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone

from rig.lab.errors import StoreInputError
from rig.lab.local import LocalSession

FINISHED = ("complete", "rejected")
TERMINAL = ("complete", "rejected", "aborted", "failed")
UNKNOWN_UNIT = "UNKNOWN"


@dataclass
class Identity:
    key: str
    name: str
    unit: str
    board: str | None
    rig: str
    operator: str
    host: str | None
    started: datetime
    simulated: bool
    status: str
    planned: int | None
    ended: datetime | None
    last_activity: datetime | None


def rig_name(meta: dict, given: str | None = None) -> str:
    if given:
        return given
    declared = meta.get("rig")
    if isinstance(declared, dict):
        declared = declared.get("name")
    if not declared:
        declared = ((meta.get("config") or {}).get("store") or {}).get("rig")
    return str(declared or meta.get("host") or "unknown")


def unit_of(meta: dict) -> tuple[str, str | None]:
    unit = meta.get("unit") or {}
    if not isinstance(unit, dict):
        return str(unit), None
    return str(unit.get("serial") or UNKNOWN_UNIT), unit.get("board")


def of(local: LocalSession, meta: dict, *, rig: str | None = None) -> Identity:
    ident = local.identity()
    serial, board = unit_of(ident)
    try:
        started = parse_utc(ident.get("start_utc") or ident.get("_first_written"))
        ended = parse_utc(meta["end_utc"]) if meta.get("end_utc") and meta.get("status") in TERMINAL else None
    except (TypeError, ValueError) as exc:
        raise StoreInputError(f"{local.folder}: metadata start_utc/end_utc is not a time ({exc})") from None
    schedule = meta.get("schedule")
    return Identity(
        key=local.key(), name=local.folder.resolve().name, unit=serial, board=board, rig=rig_name(meta, rig),
        operator=str(meta.get("operator") or ""), host=meta.get("host"), started=started,
        simulated=bool(meta.get("simulated")), status=str(meta.get("status") or "unknown"),
        planned=len(schedule) if isinstance(schedule, list) else None,
        ended=ended,
        last_activity=last_activity(local))


def last_activity(local: LocalSession) -> datetime | None:
    times = [rows[-1][-1] for rows in (local.metadata_rows(), local.events())
             if rows]
    segs = local.segments(local.last_ids()[1] - 1, with_data=False)
    times += [s.written_utc for s in segs]
    parsed = []
    for t in times:
        try:
            parsed.append(parse_utc(t))
        except (TypeError, ValueError):
            continue
    return max(parsed) if parsed else None


def parse_utc(text) -> datetime:
    """An ISO time as the rig writes it ('...Z'); naive times are taken as UTC."""
    if isinstance(text, datetime):
        return text if text.tzinfo else text.replace(tzinfo=timezone.utc)
    when = datetime.fromisoformat(str(text).replace("Z", "+00:00"))
    return when if when.tzinfo else when.replace(tzinfo=timezone.utc)
