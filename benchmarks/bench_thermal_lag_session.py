"""Thermal lag named end to end on simulated ramped thermal sessions (`rig calibrate --sim --thermal` with
`[thermal] ramp_c_per_min`); prints JSON.

Each session is the built-in simulated thermal session (its soak threshold and schedule, sampled at 50 Hz, soaks
polled every 10 s) through `--steps-c` up and down with a ramped step on each move at `--ramp` C/min; its unit
(seed) draws its temperature curves, without hysteresis, and its sensing elements lag the die thermometer by a lag
drawn from `--lag` (uniform, s; `[thermal] sim_lag_s`). The same seeds are run without a lag (clean). Figures per
sensor: the share of lag sessions where `thermal_lag` is named (`named`), the largest and the median relative
size error of the lags named, the share within 40 %, the standardised errors' RMS (1 where the stated deviations
are honest); the share of clean sessions where anything is called (named or not distinguishable), and of lag
sessions where a hysteresis is named; CPU seconds per session.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import stamp  # noqa: E402  (benchmarks/stamp.py)

from rig.commands.thermal_run import builtin_thermal_config, run_thermal_to  # noqa: E402
from rig.effects import THERMAL_HYSTERESIS, THERMAL_LAG  # noqa: E402

SENSORS = ("accel", "gyro", "mag")


def session(out: Path, seed: int, lag_s: float, ramp: float, steps_c: list[float]) -> dict:
    """One simulated ramped thermal session's `thermal.json`."""
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, steps_c=steps_c, direction="up-down", sim_hysteresis=False,
                             ramp_c_per_min=ramp, sim_lag_s=lag_s, poll_s=10.0)
    config.schedule.rate_hz = 50.0
    config.schedule.mag_every = 1
    code = run_thermal_to(out, config, sim=True, seed=seed, progress=False, echo=lambda *a, **k: None)
    if code != 0:
        raise SystemExit(f"seed {seed}, lag {lag_s:g} s: the session ended with exit {code}")
    return json.loads((out / "thermal.json").read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=4, help="seeds; each run with a lag and clean (default 4)")
    parser.add_argument("--seed", type=int, default=2026, help="the first unit's seed")
    parser.add_argument("--ramp", type=float, default=0.5, help="ramp_c_per_min (default 0.5)")
    parser.add_argument("--steps-c", default="30,70", help="set points, C, comma-separated (default 30,70)")
    parser.add_argument("--lag", default="60,150", help="the lag's range, s (default 60,150)")
    stamp.add_save_option(parser)
    args = parser.parse_args()
    steps_c = [float(v) for v in args.steps_c.split(",")]
    lag_lo, lag_hi = (float(v) for v in args.lag.split(","))
    run = stamp.start("bench_thermal_lag_session")
    rng = np.random.default_rng(args.seed)
    named = {s: 0 for s in SENSORS}
    hysteresis_called = {s: 0 for s in SENSORS}
    clean_called = {s: 0 for s in SENSORS}
    errors: dict[str, list[float]] = {s: [] for s in SENSORS}
    z: dict[str, list[float]] = {s: [] for s in SENSORS}
    cpu: list[float] = []
    sessions = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.sessions):
            seed = args.seed + i
            lag_s = float(rng.uniform(lag_lo, lag_hi))
            for lag in (lag_s, 0.0):
                started = time.process_time()
                manifest = session(Path(tmp) / f"s{i}-{'lag' if lag else 'clean'}", seed, lag, args.ramp, steps_c)
                cpu.append(time.process_time() - started)
                record = {"seed": seed, "lag_s": lag, "found": {}}
                for sensor, verdict in manifest["causes"].items():
                    effects = {f["effect"]: f for f in verdict["findings"]}
                    if lag:
                        hysteresis_called[sensor] += THERMAL_HYSTERESIS in effects
                        if THERMAL_LAG in effects:
                            f = effects[THERMAL_LAG]
                            named[sensor] += 1
                            errors[sensor].append(abs(f["magnitude"] / lag - 1.0))
                            z[sensor].append((f["magnitude"] - lag) / f["uncertainty"])
                            record["found"][sensor] = [f["magnitude"], f["uncertainty"]]
                    else:
                        clean_called[sensor] += bool(effects) or bool(verdict["undistinguished"])
                        record["found"][sensor] = sorted(effects)
                sessions.append(record)
    n = args.sessions
    figures: dict = {"cpu_s_per_session": round(float(np.mean(cpu)), 2)}
    for s in SENSORS:
        figures[f"{s}_lag_named_share"] = named[s] / n
        figures[f"{s}_clean_called_share"] = clean_called[s] / n
        figures[f"{s}_lag_session_hysteresis_share"] = hysteresis_called[s] / n
        if errors[s]:
            figures[f"{s}_lag_relerr_max"] = round(float(np.max(errors[s])), 4)
            figures[f"{s}_lag_relerr_median"] = round(float(np.median(errors[s])), 4)
            figures[f"{s}_lag_within_40pct_share"] = float(np.mean(np.asarray(errors[s]) <= 0.4))
            figures[f"{s}_lag_z_rms"] = round(float(np.sqrt(np.mean(np.square(z[s])))), 3)
    stamp.report(run, figures=figures, details={"sessions": sessions, "ramp_c_per_min": args.ramp,
                                                "steps_c": steps_c, "lag_range_s": [lag_lo, lag_hi]},
                 save=args.save)


if __name__ == "__main__":
    main()
