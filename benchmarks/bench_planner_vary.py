"""Benchmark: the planner's plan at half of today's default table time against today's default plan, on the second
independent simulator. Prints JSON.

`bench_planner.py` measures the claim on the rig's own simulator; a plan that is only better there may be better
only because the planner and the simulator share the rig's model. Here both plans run on
`tests/independent_vary/vary_sim.py` (written from the spec alone, its own unit, noise and truth: `--variant`,
default its baseline) through its explicit schedule (`vary_sim.Schedule`):

- today's default plan: the configuration's (`rig/configs/sim.toml`) orientations (`rig.schedule.plan_orientations`),
  hold length and move speed and acceleration;
- the planner's plan (`rig.planner.plan_for_budget`, as `bench_planner.py` and `rig plan --budget-s` use it) for half
  of the default session's measured table time;

both with the same orientations in the same order, the same holds and move limits as on the rig, each move
followed by the rig's settle wait and its two status polls (what `rig.planner.eta` counts), so that the table
time is the rig's. Seed k is the same simulated unit under both plans (vary_sim draws the unit first).

Every session is calibrated by `rig calibrate --from DIR` as a user would run it (a subprocess of the `rig` on
PATH, running the same `rig` package this benchmark imports), and again with `--holds-only` (the accelerometer
and magnetometer from their hold means alone) and with `--settle-s 0` (the default drops 0.5 s of every hold of
an interchange session as settling; these holds begin settled, as the rig's own do, which the rig's own folders
are calibrated as). H error: relative Frobenius against vary_sim's truth (`vary_sim.score`), median over seeds.
The target is met for a sensor when the half-time plan's median H error is at most the default's.

    python benchmarks/bench_planner_vary.py [--seeds 10] [--variant baseline] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import rig
from rig import planner
from rig.config import RigConfig, load_config
from rig.schedule import Orientation, plan_orientations

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "independent_vary"))
import vary_sim as vs  # noqa: E402

SENSORS = planner.SENSORS
# how each session is calibrated: name -> extra arguments of `rig calibrate --from DIR`
MODES: dict[str, tuple[str, ...]] = {"as_user": (), "holds_only": ("--holds-only",), "settle_0": ("--settle-s", "0"),
                                     "settle_0_holds_only": ("--settle-s", "0", "--holds-only")}


def rig_schedule(config: RigConfig, orientations: list[Orientation], hold_s: float) -> vs.Schedule:
    """The rig's plan as vary_sim's schedule: after each move the table's settle time and two status polls (the
    arrival is seen at a poll and the settle counted from one), as `rig.planner.eta` counts them."""
    t, s = config.turntable, config.schedule
    return vs.Schedule(tuple((o.outer_deg, o.inner_deg) for o in orientations), (hold_s,) * len(orientations),
                       t.speed_dps, t.accel_dps2, t.settle_s + 2 * t.poll_every / s.rate_hz)


def run_seed(cfg: vs.Config, schedule: vs.Schedule, seed: int, work: Path, name: str) -> dict:
    """One vary_sim session of `schedule`, calibrated in every mode; H errors in %, or the CLI's error line."""
    session = work / f"{name}_s{seed}"
    truth = json.loads(vs.write_session(vs.generate(cfg, seed, schedule), session).read_text())
    out: dict = {"seed": seed, "H_err_pct": {}}
    for mode, extra in MODES.items():
        dest = work / f"{name}_s{seed}_{mode}"
        proc = vs.run_cli(session, dest, *extra)
        if proc.returncode != 0:
            out.setdefault("errors", {})[mode] = (proc.stderr.strip().splitlines() or ["?"])[-1]
            continue
        cal = json.loads((dest / "calibration.json").read_text())
        out["table_time_s"] = cal["table_time_s"]
        out["H_err_pct"][mode] = {s: float(e["H_err_pct"]) for s, e in vs.score(cal, truth).items()}
    return out


def campaign(cfg: vs.Config, schedule: vs.Schedule, seeds: list[int], work: Path, name: str) -> list[dict]:
    runs = []
    for seed in seeds:
        runs.append(run_seed(cfg, schedule, seed, work, name))
        print(json.dumps({name: runs[-1]}), file=sys.stderr, flush=True)
    return runs


def median_err(runs: list[dict], mode: str) -> dict[str, float]:
    return {s: float(np.median([r["H_err_pct"][mode][s] for r in runs if mode in r["H_err_pct"]])) for s in SENSORS}


def compare(default: list[dict], half: list[dict], mode: str, against: str | None = None) -> dict:
    """Per sensor: median H error of each plan (the default's in mode `against`, if given), their ratio, whether
    the target (ratio <= 1) is met, and on how many seeds (the same unit under both plans) the half plan did better."""
    d, h = median_err(default, against or mode), median_err(half, mode)
    paired = [(a["H_err_pct"][against or mode], b["H_err_pct"][mode]) for a, b in zip(default, half)
              if (against or mode) in a["H_err_pct"] and mode in b["H_err_pct"]]
    return {s: {"default_median_pct": round(d[s], 6), "half_median_pct": round(h[s], 6),
                "ratio": round(h[s] / d[s], 3), "target_met": h[s] <= d[s],
                "half_better_on_seeds": f"{sum(b[s] <= a[s] for a, b in paired)}/{len(paired)}"} for s in SENSORS}


def plan_info(schedule: vs.Schedule, runs: list[dict], eta_s: float) -> dict:
    times = [r["table_time_s"] for r in runs if "table_time_s" in r]
    return {"orientations": len(schedule.angles_deg), "hold_s": schedule.hold_s[0], "speed_dps": schedule.vmax_dps,
            "accel_dps2": schedule.amax_dps2, "settle_s_per_move": round(schedule.settle_s, 3),
            "planner_eta_s": round(eta_s, 2),
            "table_time_s": ({"median": float(np.median(times)), "min": min(times), "max": max(times)}
                             if times else None),
            "failed": [{"seed": r["seed"], **r["errors"]} for r in runs if r.get("errors")]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--variant", default="baseline", choices=list(vs.VARIANTS),
                    help="vary_sim's unit, noise and truth model (its plan is replaced by the rig's)")
    ap.add_argument("--keep", type=Path, metavar="DIR", help="keep the sessions and calibrations in DIR")
    args = ap.parse_args()
    if shutil.which("rig") is None:
        raise SystemExit("bench_planner_vary: `rig` is not on PATH (activate the venv where rig is installed)")
    # the `rig` subprocesses calibrate with the same package this process plans with
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(Path(rig.__file__).parents[1]),
                                                           os.environ.get("PYTHONPATH")) if p)
    t_start = time.perf_counter()
    seeds, cfg, config = list(range(args.seeds)), vs.config_for(args.variant), load_config(None)
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        default_orient = plan_orientations(config.schedule.orientations)
        default_sched = rig_schedule(config, default_orient, config.schedule.hold_s)
        default = campaign(cfg, default_sched, seeds, work, "default")
        times = [r["table_time_s"] for r in default if "table_time_s" in r]
        if not times:
            raise SystemExit("bench_planner_vary: no default session was calibrated: "
                             + json.dumps([r.get("errors") for r in default]))
        default_time = float(np.median(times))
        t0 = time.perf_counter()
        plan = planner.plan_for_budget(config, 0.5 * default_time, planner.NoiseModel())
        planning_s = time.perf_counter() - t0
        half_sched = rig_schedule(config, plan.schedule, plan.hold_s)
        half = campaign(cfg, half_sched, seeds, work, "half")
    primary = compare(default, half, "as_user")
    print(json.dumps({
        "benchmark": "planner at half the default's table time vs today's default plan, second independent "
                     "simulator",
        "simulator": f"tests/independent_vary/vary_sim.py, variant {args.variant!r} (its own unit, noise and truth)",
        "sample_rates_hz": {s: getattr(cfg, f"{s}_hz") or cfg.rate_hz for s in SENSORS},
        "seeds": len(seeds), "H_error": "relative Frobenius, %, median over seeds",
        "default_plan": plan_info(default_sched, default, planner.eta(config, default_orient, config.schedule.hold_s)),
        "half_plan": {"budget_s": round(0.5 * default_time, 3), "planning_s": round(planning_s, 3),
                      **plan_info(half_sched, half, plan.eta_s)},
        "as_user": primary,
        "holds_only": compare(default, half, "holds_only"),
        "settle_0": compare(default, half, "settle_0"),
        "settle_0_holds_only": compare(default, half, "settle_0_holds_only"),
        "half_as_user_over_default_holds_only": compare(default, half, "as_user", against="holds_only"),
        "target_met": {**{s: primary[s]["target_met"] for s in SENSORS},
                       "all": all(primary[s]["target_met"] for s in SENSORS)},
        "calibrate_modes": {m: " ".join(["rig calibrate --from DIR --out OUT --no-progress", *x])
                            for m, x in MODES.items()},
        "wall_s": round(time.perf_counter() - t_start, 1),
    }, indent=2))


if __name__ == "__main__":
    main()
