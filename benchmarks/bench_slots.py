"""Benchmark: several units in one session against each unit alone (`[[slots]]`, rig/configs/four-slots.toml).

For each seed, one session of N slots (bsn boards on their own buses, at their lever arms, one mounted turned)
and, for each slot, a session of that slot alone (the same simulated unit: its errors and noise come from the
seed and the slot's name). Prints JSON: the table time of the N-slot session against one unit's, each unit's H
error (every sensor, % Frobenius, against the simulator's truth) against its own single-unit session's, the lever
arms found, and units per hour of table time. Targets (issue): table time ratio <= 1.15, each unit's H error
within 1.1x of its single-unit session's (median over seeds), no worse than 1.25x for any.
Usage: python benchmarks/bench_slots.py [--seeds 10] [--orientations 20] [--hold-s 5] [--slots 4] [--save]"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from importlib import resources
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import stamp  # noqa: E402  (benchmarks/stamp.py)

from procedures.orchestrator import RigSpec, SessionOrchestrator  # noqa: E402
from rig.assembly import build_rig  # noqa: E402
from rig.config import load_config  # noqa: E402


def configuration(orientations: int, hold_s: float, n_slots: int, path: str | None = None):
    path = path or str(resources.files("rig.configs").joinpath("four-slots.toml"))
    config = load_config(Path(path))
    config.schedule.orientations, config.schedule.hold_s = orientations, hold_s
    if n_slots > len(config.slots):
        raise SystemExit(f"--slots {n_slots}: {path} declares {len(config.slots)}")
    return replace(config, slots=config.slots[:n_slots])


def session(config, seed: int, folder: Path, trial: int = 0) -> tuple[dict, float, float]:
    """({slot: {"H": {sensor: %}}}, table time s, wall s) of one session (`trial`: the noise trial)."""
    t0 = time.perf_counter()
    outcome = SessionOrchestrator(folder, build_rig, plots=False).start(config, RigSpec(True, seed, trial=trial))
    wall = time.perf_counter() - t0
    per = {}
    for name, one in outcome.slots.items():
        if one.status != "complete":
            raise SystemExit(f"seed {seed} slot {name}: {one.status}: {one.reason}")
        per[name] = {"H": one.h_error_pct}
    return per, float(outcome.table_time_s), wall


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--orientations", type=int, default=20)
    ap.add_argument("--hold-s", type=float, default=5.0)
    ap.add_argument("--slots", type=int, default=4)
    ap.add_argument("--config", default=None, help="a configuration of slots (default rig/configs/four-slots.toml)")
    ap.add_argument("--null", action="store_true",
                    help="also each slot alone in a second noise trial: the scatter of the same ratio when nothing "
                         "differs but the noise")
    ap.add_argument("--save", action="store_true")
    args = ap.parse_args()
    run = stamp.start("bench_slots")
    config = configuration(args.orientations, args.hold_s, args.slots, args.config)
    names = [s.name for s in config.slots]
    ratios: dict[str, list[float]] = {}       # "slot/sensor" -> per seed: H error together / alone
    errors: dict[str, tuple[list[float], list[float]]] = {}      # "slot/sensor" -> (together, alone) per seed
    null: dict[str, list[float]] = {}         # "slot/sensor" -> per seed: H error alone in another noise trial
    together_s, alone_s, wall_together, wall_alone, runs = [], [], [], [], []
    with tempfile.TemporaryDirectory() as d:
        for seed in range(args.seeds):
            many, table_many, wall_many = session(config, seed, Path(d) / f"many-{seed}")
            together_s.append(table_many)
            wall_together.append(wall_many)
            record = {"seed": seed, "table_time_s": table_many, "slots": {}}
            for slot in config.slots:
                alone, table_one, wall_one = session(replace(config, slots=(slot,)), seed,
                                                     Path(d) / f"one-{seed}-{slot.name}")
                alone_s.append(table_one)
                wall_alone.append(wall_one)
                for sensor, pct in many[slot.name]["H"].items():
                    ratios.setdefault(f"{slot.name}/{sensor}", []).append(pct / alone[slot.name]["H"][sensor])
                    pair = errors.setdefault(f"{slot.name}/{sensor}", ([], []))
                    pair[0].append(pct)
                    pair[1].append(alone[slot.name]["H"][sensor])
                if args.null:
                    again, _, _ = session(replace(config, slots=(slot,)), seed, Path(d) / f"null-{seed}-{slot.name}",
                                          trial=1)
                    for sensor, pct in again[slot.name]["H"].items():
                        null.setdefault(f"{slot.name}/{sensor}", []).append(pct)
                record["slots"][slot.name] = {"together_H_pct": many[slot.name]["H"],
                                              "alone_H_pct": alone[slot.name]["H"], "alone_table_time_s": table_one}
            runs.append(record)
    # each unit's H error together against alone: the ratio of the medians over seeds (the two sessions draw their
    # own noise, so a seed's own ratio scatters as the errors do)
    median_ratio = {key: float(np.median(a) / np.median(b)) for key, (a, b) in errors.items()}
    pooled = {sensor: float(np.median([x for k, (a, _) in errors.items() if k.endswith("/" + sensor) for x in a])
                            / np.median([x for k, (_, b) in errors.items() if k.endswith("/" + sensor) for x in b]))
              for sensor in ("accel", "gyro", "mag")}
    table_ratio = float(np.median(together_s) / np.median(alone_s))
    figures = {
        "slots": len(names), "board": ",".join(sorted({s.board for s in config.slots})), "seeds": args.seeds, "orientations": args.orientations, "hold_s": args.hold_s,
        "table_time_n_slots_s": float(np.median(together_s)), "table_time_one_unit_s": float(np.median(alone_s)),
        "table_time_ratio": table_ratio,
        "H_error_ratio_worst_unit": max(median_ratio.values()),
        "H_error_ratio_median_of_units": float(np.median(list(median_ratio.values()))),
        **{f"H_error_ratio_all_units_{sensor}": value for sensor, value in pooled.items()},
        "units_per_hour_n_slots": 3600.0 * len(names) / float(np.median(together_s)),
        "units_per_hour_one_unit": 3600.0 / float(np.median(alone_s)),
        "wall_s_n_slots_session": float(np.median(wall_together)), "wall_s_one_unit_session": float(np.median(wall_alone)),
        **({"H_error_ratio_worst_unit_null": max(float(np.median(null[k]) / np.median(errors[k][1])) for k in null),
            "H_error_ratio_median_of_units_null": float(np.median([np.median(null[k]) / np.median(errors[k][1])
                                                                    for k in null]))} if null else {}),
        "target_table_time_ratio_le_1_15": table_ratio <= 1.15,
        "target_H_ratio_each_unit_le_1_1": max(median_ratio.values()) <= 1.1,
        "target_H_ratio_any_unit_le_1_25": max(median_ratio.values()) <= 1.25,
    }
    stamp.report(run, figures, {"H_error_ratio_of_medians": median_ratio,
                                "H_error_ratio_per_seed": ratios, "runs": runs}, save=args.save)


if __name__ == "__main__":
    main()
