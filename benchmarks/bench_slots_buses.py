"""Benchmark: eight units on two I2C buses at 100 Hz (rig/configs/eight-slots.toml), the bus time a session used
per tick against `rig plan`'s prediction, and every tick recorded or counted as skipped.

Two sessions of the same simulated table, read through `rig.bus_budget`'s counting wrappers on every bus:
- "wire": transfers are counted and stamped, the simulated clock does not pay for them (the bus time per tick the
  drivers' transfers need, against the plan's mean and busiest tick per bus; target within 20 %);
- "paid": the clock pays each transfer's wire time, as real buses make the sampler wait (its skipped ticks, late
  reads, redone steps and outcome; its bus time per tick as each bus's wire seconds over the ticks read, since
  with the wire paid a tick's transfers run back to back and the gap rule of `ticks_of` merges ticks).
Per slot: rows recorded + ticks skipped + ticks discarded with a redone step against ticks (every tick on the grid or
counted).
Usage: python benchmarks/bench_slots_buses.py [--orientations 9] [--hold-s 2] [--seed 0] [--save]"""

from __future__ import annotations

import argparse
import json
import sqlite3
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import stamp  # noqa: E402  (benchmarks/stamp.py)

from procedures.orchestrator import RigSpec, SessionOrchestrator  # noqa: E402
from rig.assembly import assemble_slots  # noqa: E402
from rig.board import i2c_clock_hz  # noqa: E402
from rig.bus_budget import WireTimedLog  # noqa: E402
from rig.commands.plan import simulated_bus_loads  # noqa: E402
from rig.config import load_config  # noqa: E402


def session(config, seed: int, folder: Path, charge: bool):
    logs: list[WireTimedLog] = []

    def factory(cfg, spec):
        def traffic(clock):
            logs.append(WireTimedLog(clock, i2c_clock_hz(cfg.chips), charge=charge))
            return logs[-1]
        return assemble_slots(cfg, simulate=True, seed=spec.seed or 0, trial=spec.trial, traffic=traffic)

    t0 = time.perf_counter()
    outcome = SessionOrchestrator(folder, factory, plots=False).start(config, RigSpec(True, seed))
    wall = time.perf_counter() - t0
    per_slot = {}
    for name in outcome.slots:
        with sqlite3.connect(folder / name / "session.sqlite") as db:
            rows = db.execute("SELECT sum(n_rows) FROM segment").fetchone()[0] or 0
            acq = json.loads(db.execute("SELECT value FROM metadata WHERE key = 'acquisition' ORDER BY id DESC")
                             .fetchone()[0])
        per_slot[name] = {"status": outcome.slots[name].status, "rows": int(rows), **acq}
    return outcome, logs[0], per_slot, wall


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--orientations", type=int, default=9)
    ap.add_argument("--hold-s", type=float, default=2.0)
    ap.add_argument("--seed", type=int, default=0)
    stamp.add_save_option(ap)
    args = ap.parse_args()
    run = stamp.start("bench_slots_buses")
    config = load_config(Path(str(resources.files("rig.configs").joinpath("eight-slots.toml"))))
    config.schedule.orientations, config.schedule.hold_s = args.orientations, args.hold_s
    rate = config.schedule.rate_hz
    predicted = {load.bus: load for load in simulated_bus_loads(config)}
    figures: dict = {"slots": len(config.slots), "rate_hz": rate, "i2c_clock_hz": i2c_clock_hz(config.chips),
                     "orientations": args.orientations, "hold_s": args.hold_s, "seed": args.seed}
    details: dict = {}
    with tempfile.TemporaryDirectory() as d:
        for mode, charge in (("wire", False), ("paid", True)):
            outcome, log, per_slot, wall = session(config, args.seed, Path(d) / mode, charge)
            ticks = log.ticks_of(1.0 / rate)
            read = max(s["ticks"] - s["skipped_ticks"] for s in per_slot.values())
            paid_s = log.bus_seconds()
            figures[f"{mode}_status"] = outcome.status
            figures[f"{mode}_table_time_s"] = float(outcome.table_time_s or 0.0)
            figures[f"{mode}_wall_s"] = wall
            for bus, load in predicted.items():
                used = np.array([tick.get(bus, 0.0) for tick in ticks])
                key = bus.replace(" ", "_")
                if mode == "wire":
                    figures[f"{key}_predicted_mean_tick_ms"] = load.seconds_per_tick * 1e3
                    figures[f"{key}_predicted_worst_tick_ms"] = load.worst_tick_s * 1e3
                figures[f"{mode}_{key}_used_mean_tick_ms"] = float(used.mean() * 1e3)
                figures[f"{mode}_{key}_used_median_tick_ms"] = float(np.median(used) * 1e3)
                figures[f"{mode}_{key}_used_over_predicted_mean"] = float(used.mean() / load.seconds_per_tick)
                figures[f"{mode}_{key}_wire_ms_per_tick_read"] = paid_s.get(bus, 0.0) / read * 1e3
                figures[f"{mode}_{key}_wire_per_tick_read_over_predicted_mean"] = (paid_s.get(bus, 0.0) / read
                                                                                   / load.seconds_per_tick)
            figures[f"{mode}_ticks_accounted_every_slot"] = all(s["rows"] + s["skipped_ticks"] + s["ticks_discarded"] == s["ticks"]
                                                               for s in per_slot.values())
            figures[f"{mode}_skipped_ticks_max_slot"] = max(s["skipped_ticks"] for s in per_slot.values())
            figures[f"{mode}_late_reads_max_slot"] = max(s["late_reads"] for s in per_slot.values())
            figures[f"{mode}_ticks_discarded_max_slot"] = max(s["ticks_discarded"] for s in per_slot.values())
            figures[f"{mode}_steps_redone_max_slot"] = max(s["steps_redone"] for s in per_slot.values())
            figures[f"{mode}_slots_rejected"] = sum(s["status"] != "complete" for s in per_slot.values())
            figures[f"{mode}_ticks_read"] = read
            details[f"{mode}_slots"] = per_slot
    figures["target_wire_budget_within_20pct"] = all(
        abs(figures[f"wire_{bus.replace(' ', '_')}_used_over_predicted_mean"] - 1) <= 0.2 for bus in predicted)
    figures["target_paid_budget_within_20pct"] = all(
        abs(figures[f"paid_{bus.replace(' ', '_')}_wire_per_tick_read_over_predicted_mean"] - 1) <= 0.2
        for bus in predicted)
    stamp.report(run, figures, details, save=args.save)


if __name__ == "__main__":
    main()
