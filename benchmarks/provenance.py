"""What a benchmark's figures were measured on: the fields every benchmark's JSON starts with.

A time means little without the code it timed (`commit`, with `-dirty` when the tree had uncommitted changes),
the machine, and how busy it was (`load`: the 1, 5 and 15 minute load averages when the run started; the
machine is shared, so a slow figure under load 6 is not a regression).
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def commit() -> str:
    """The checked-out commit, `-dirty` appended when tracked files differ from it; "unknown" outside git."""
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("-dirty" if dirty else "")


def machine() -> dict:
    return {"host": platform.node(), "system": platform.platform(), "processor": platform.machine(),
            "cpus": os.cpu_count(), "python": platform.python_version()}


def provenance(benchmark: str) -> dict:
    """{benchmark, date (UTC, ISO 8601), commit, machine, load} for the head of a benchmark's JSON."""
    return {"benchmark": benchmark,
            "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "commit": commit(), "machine": machine(),
            "load": [round(x, 2) for x in os.getloadavg()]}
