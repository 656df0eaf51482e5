"""Child process of the SIGKILL tests: appends holds and moves to a new session until it is killed.

usage: append_until_killed.py FOLDER loop           -- append as fast as possible, print "committed J"
       append_until_killed.py FOLDER stall STEP     -- stop inside the transaction of hold STEP, print "stalled"
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from synthetic_holds import hold_arrays, move_arrays

from rig.store import SessionStore

MAX_STEPS = 100_000


def main(folder: Path, mode: str, stall_step: int | None) -> None:
    store = SessionStore.create(folder, {"operator": "kill-test"})
    writing = {"step": None}

    def stall_inside_transaction(statement: str) -> None:
        if writing["step"] == stall_step and statement.startswith("INSERT INTO array"):
            print("stalled", flush=True)
            time.sleep(600)

    if mode == "stall":
        store._conn.set_trace_callback(stall_inside_transaction)
    for step in range(MAX_STEPS):
        writing["step"] = step
        store.append_hold(step, **hold_arrays(step))
        print(f"committed {step}", flush=True)
        store.append_move(step, **move_arrays(step))


if __name__ == "__main__":
    main(Path(sys.argv[1]), sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else None)
