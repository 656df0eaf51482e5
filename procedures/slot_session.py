"""The layout of a session of several slots: `out/X/slots.json` (the manifest) beside one ordinary session folder
per slot, `out/X/<slot>/`, so every per-session tool works on a slot unchanged.

The manifest says which slots the table carried (board, serial, buses, lever arm, mount, switch channel, folder),
how the rig was built (simulated or not, seed, trial) and the configuration, so `rig resume out/X` rebuilds the
same table; once the session ends it also holds the shared table time and each slot's end.
"""

from __future__ import annotations

import json
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rig.errors import InputError

MANIFEST = "slots.json"
SCHEMA = "rig-slots/1"


def is_slots_session(folder: Path) -> bool:
    return (Path(folder) / MANIFEST).is_file()


def read_manifest(folder: Path) -> dict:
    path = Path(folder) / MANIFEST
    try:
        manifest = json.loads(path.read_text())
    except (OSError, ValueError) as e:
        raise InputError(f"{path}: cannot read the slots manifest: {e}") from None
    if not isinstance(manifest, dict) or manifest.get("schema") != SCHEMA or not manifest.get("slots"):
        raise InputError(f"{path}: not a slots manifest (schema {SCHEMA})")
    return manifest


def slot_folders(folder: Path) -> list[Path]:
    """Each slot's session folder of a slots session (each is a session of its own unit), [] for any other folder."""
    if not is_slots_session(folder):
        return []
    return [Path(folder) / str(slot.get("folder") or slot["name"]) for slot in read_manifest(folder)["slots"]]


def new_manifest(config, spec, configs: dict) -> dict:
    """The manifest written before recording starts: the slots, their serials, how to rebuild the rig."""
    return {"schema": SCHEMA, "id": str(uuid.uuid4()),
            "slots": [{**slot.to_dict(), "serial": configs[slot.name].serial, "folder": slot.name}
                      for slot in config.slots],
            "simulated": spec.simulated, "seed": spec.seed, "time_scale": spec.time_scale, "trial": spec.trial,
            "config": config.to_dict()}


def shared_table(folder: Path, units: int, table_time_s: float | None) -> dict:
    """What each slot's session and calibration record of the table it shared (`table` key): the slots session's
    id (the manifest's, else its folder's name), how many units the table carried and its table time in s."""
    try:
        session = read_manifest(folder).get("id") or Path(folder).name
    except InputError:
        session = Path(folder).name
    return {"session": str(session), "units": int(units), "table_time_s": table_time_s}


@dataclass
class RecordingRig:
    """What `procedures.session.record` drives: the shared table and clock, the slots' boards as one."""

    table: Any
    board: Any
    clock: Any
    config: Any


@dataclass
class SlotsOutcome:
    """How a session of several slots ended: one `Outcome` per slot, in the configuration's order."""

    folder: Path
    slots: dict = field(default_factory=dict)       # name -> procedures.orchestrator.Outcome
    table_time_s: float | None = None

    @property
    def status(self) -> str:
        statuses = {o.status for o in self.slots.values()}
        for status in ("aborted", "failed", "rejected"):
            if status in statuses:
                return status
        return "complete"
