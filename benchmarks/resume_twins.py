"""A resumed session against its uninterrupted twin (same seed): H errors, holds lost or duplicated; prints JSON.

Each session runs in this process on the simulated rig in virtual time. The interrupted one is stopped at a
random gyro read, either as SIGKILL would stop it (nothing of the process runs after: the status stays
"running") or by a stop signal (SIGINT/SIGTERM: the session is marked aborted), then finished with the same
code path as `rig resume`. Reported per session: where it stopped, the H error of every sensor against the
simulator's truth for both twins and their ratio, the holds and moves used, and any move spanning a resume.

    python benchmarks/resume_twins.py --sessions 12 [--seed0 0] [--orientations 20]
"""

from __future__ import annotations

import argparse
import json
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from procedures.orchestrator import RigSpec, SessionOrchestrator  # noqa: E402
from rig.commands.common import build_rig  # noqa: E402
from rig.config import load_config  # noqa: E402
from rig.errors import StopSignal  # noqa: E402
from rig.store import SessionStore  # noqa: E402
from rig.store.assemble import used_segments  # noqa: E402


class Killed(BaseException):
    """Stands for SIGKILL: raised from a sensor read, caught by nothing in the rig."""


def stopping_factory(at_read: int | None, how: str):
    """A rig factory whose gyro read number `at_read` raises Killed (how="kill") or StopSignal(how)."""
    def factory(config, spec):
        rig = build_rig(config, spec)
        if at_read is None:
            return rig
        triad = rig.board.triads["gyro"]
        read, count = triad.read_raw, [0]

        def read_raw():
            count[0] += 1
            if count[0] == at_read:
                raise Killed() if how == "kill" else StopSignal(getattr(signal, how))
            return read()
        triad.read_raw = read_raw
        return rig
    return factory


def h_errors(folder: Path) -> dict[str, float]:
    cal = json.loads((folder / "calibration.json").read_text())["sensors"]
    truth = json.loads((folder / "truth.json").read_text())["sensors"]
    return {s: float(np.linalg.norm(np.array(cal[s]["H"]) - np.array(truth[s]["H"])) / np.linalg.norm(truth[s]["H"]))
            for s in cal}


def run_twins(root: Path, seed: int, at_read: int, how: str, orientations: int) -> dict:
    config = load_config()
    config.schedule.orientations = orientations
    spec = RigSpec(simulated=True, seed=seed)
    twin, cut = root / f"twin-{seed}", root / f"cut-{seed}"
    SessionOrchestrator(twin, stopping_factory(None, how)).start(config, spec)
    first = "completed"
    try:
        first = SessionOrchestrator(cut, stopping_factory(at_read, how)).start(config, spec).status
    except Killed:
        first = "killed"
    with SessionStore.open(cut) as store:
        before = store.completed_holds()
        status_before = store.status[0]
    outcome = SessionOrchestrator(cut, stopping_factory(None, how)).resume()
    with SessionStore.open(cut) as store:
        segments = used_segments(store._db)
        data = store.to_session_data()
        resumes = store.resume_times()
        stored_moves = [step for (step,) in store._db.execute("SELECT step FROM segment WHERE phase = 'move'")]
    moves = [step for _, phase, step in segments if phase == "move"]
    holds = [j for j, _ in data.hold_rows()]
    spanning = [m.step for m in data.moves("gyro") for t in resumes if m.t[0] < t <= m.t[-1]]
    e_twin, e_cut = h_errors(twin), h_errors(cut)
    return {"seed": seed, "stopped_at_read": at_read, "how": how, "first_run": first, "status_before": status_before,
            "holds_before_resume": len(before), "status": outcome.status, "verdict": outcome.verdict,
            "holds_lost": sorted(set(range(orientations)) - set(holds)),
            "holds_duplicated": len(holds) - len(set(holds)),
            "moves_stored_twice": len(stored_moves) - len(set(stored_moves)), "moves_used": len(moves),
            "moves_spanning_a_resume": spanning,
            "H_error_twin": e_twin, "H_error_resumed": e_cut,
            "ratio": {s: e_cut[s] / e_twin[s] for s in e_twin}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sessions", type=int, default=12)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--orientations", type=int, default=20)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed0)
    reads_per_session = args.orientations * 630
    t0 = time.perf_counter()
    runs = []
    with tempfile.TemporaryDirectory() as d:
        for k in range(args.sessions):
            how = ("kill", "SIGINT", "SIGTERM")[k % 3]
            runs.append(run_twins(Path(d), args.seed0 + k, int(rng.integers(50, reads_per_session - 700)), how,
                                  args.orientations))
    sensors = sorted(runs[0]["ratio"])
    summary = {s: {"max_ratio": max(r["ratio"][s] for r in runs),
                   "median_ratio": statistics.median(r["ratio"][s] for r in runs)} for s in sensors}
    print(json.dumps({
        "benchmark": "resume_twins", "sessions": len(runs), "orientations": args.orientations,
        "holds_lost": sum(len(r["holds_lost"]) for r in runs),
        "holds_duplicated": sum(r["holds_duplicated"] for r in runs),
        "moves_stored_twice": sum(r["moves_stored_twice"] for r in runs),
        "moves_spanning_a_resume": sum(len(r["moves_spanning_a_resume"]) for r in runs),
        "not_complete": [r["seed"] for r in runs if r["status"] != "complete"],
        "H_error_ratio": summary, "seconds": round(time.perf_counter() - t0, 1), "runs": runs}, indent=2))


if __name__ == "__main__":
    main()
