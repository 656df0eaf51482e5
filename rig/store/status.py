"""The statuses a session can have, and the metadata a change of status records: the store writes them, and the
orchestrator reads them to decide whether a session can be resumed.
"""

from __future__ import annotations

from pathlib import Path

from rig.store.schema import utc_now

# complete: recorded, calibrated, verdict PASS (or no limits); rejected: the same with verdict FAIL;
# aborted: stopped by a signal; failed: a fault (hardware, data, disk) ended it. All but complete and
# rejected can be resumed.
STATUSES = ("running", "complete", "rejected", "aborted", "failed")
TERMINAL_STATUSES = ("complete", "rejected", "aborted", "failed")
FINISHED_STATUSES = ("complete", "rejected")


def status_changes(path: Path, status: str, reason: str, extra: dict) -> dict:
    """The metadata a change to `status` records: `extra`, the status and its reason, and for a terminal status
    `end_utc`. ValueError naming the session file `path` if `status` is not one of STATUSES."""
    if status not in STATUSES:
        raise ValueError(f"{path}: status {status!r} is not one of {', '.join(STATUSES)}")
    changes = {**extra, "status": status, "status_reason": reason}
    if status in TERMINAL_STATUSES:
        changes["end_utc"] = utc_now()
    return changes
