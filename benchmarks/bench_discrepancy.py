"""Discrepancy analysis benchmark; prints JSON.

- analysis time of one 26-hold (20 orientations + 6 revisits) session, replay included (target <= 10 s);
- false-claim rate: share of clean sessions (no effect) with any finding;
- per effect and sensor: detection rate (right name and sensor), share also sized within 25 % (or 4 sigma),
  median held-out residual reduction 1 - after/before, and wrong-name claims.
- optionally (--sweep N) the detection rate at 1/4, 1/2 and 1x the lower end of each realistic range.
Usage: python benchmarks/bench_discrepancy.py [--clean 100] [--per-effect 20] [--sweep 8]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fixtures.world.draw import hidden_effect_cases  # noqa: E402
from procedures.replay import replay_comparison  # noqa: E402
from rig.discrepancy import analyze  # noqa: E402
from tests.discrepancy.conftest import blind, identifiable_magnitude, session_for  # noqa: E402

EFFECTS = hidden_effect_cases()   # every drawable effect of the registry, with the session it needs


def timing(repeats: int = 5) -> dict:
    times = []
    for seed in range(repeats):
        session, _ = session_for([], 500 + seed)
        t0 = time.perf_counter()
        analyze(session, replay=replay_comparison)
        times.append(time.perf_counter() - t0)
    return {"analysis_s_median": statistics.median(times), "analysis_s_max": max(times), "holds": 26,
            "orientations": 20, "repeats": repeats}


def false_claims(n: int) -> dict:
    hits, claimed = 0, {}
    for seed in range(n):
        session, _ = session_for([], 10_000 + seed)
        rep = blind(session)
        if rep["findings"]:
            hits += 1
            for f in rep["findings"]:
                claimed[f"{f['effect']}:{f['sensor']}"] = claimed.get(f"{f['effect']}:{f['sensor']}", 0) + 1
    return {"sessions": n, "false_claim_rate": hits / n, "claimed": claimed}


def detection(n: int) -> dict:
    out = {}
    for name, sensor, design in EFFECTS:
        found = sized = wrong = 0
        gains, mags = [], []
        for seed in range(n):
            session, (effect,) = session_for([(name, sensor)], 20_000 + seed, **design)
            rep = blind(session)
            truth = identifiable_magnitude(effect)
            mags.append(truth)
            wrong += sum(1 for f in rep["findings"] if (f["effect"], f["sensor"]) != (name, sensor))
            hit = [f for f in rep["findings"] if (f["effect"], f["sensor"]) == (name, sensor)]
            if not hit:
                continue
            f = hit[0]
            found += 1
            err = abs(abs(f["magnitude"]) - truth)
            sized += err <= max(0.25 * truth, 4 * f["uncertainty"])
            gains.append(1 - f["heldout_rms_after"] / f["heldout_rms_before"])
        out[f"{name}:{sensor}"] = {"sessions": n, "detection_rate": found / n, "sized_rate": sized / n,
                                   "wrong_claims": wrong, "median_heldout_reduction": statistics.median(gains) if gains else None,
                                   "magnitude_range": [min(mags), max(mags)], "design": design}
    return out


PAIRS = [
    [("temperature_bias", "accel"), ("gyro_g_sensitivity", "gyro")],
    [("time_offset", "gyro"), ("mag_offset_flip", "mag")],
    [("supply_ratiometric", "accel"), ("accel_scale_nonlinearity", "accel")],
    [("gyro_g_sensitivity", "gyro"), ("gyro_scale_asymmetry", "gyro")],
    [("temperature_bias", "mag"), ("table_magnetic_disturbance", "mag")],
    [("bias_drift", "accel"), ("table_axis_misalignment", "rig")],
]


def two_effects(n: int) -> dict:
    """Both effects of a pair named (and nothing else claimed)."""
    out = {}
    for pair in PAIRS:
        both = exact = 0
        for seed in range(n):
            session, _ = session_for(pair, 40_000 + seed)
            names = {(f["effect"], f["sensor"]) for f in blind(session)["findings"]}
            both += set(pair) <= names
            exact += set(pair) == names
        out["+".join(f"{a}:{b}" for a, b in pair)] = {"sessions": n, "both_found": both / n, "exactly_these": exact / n}
    return out


def size_sweep(n: int, fractions=(0.25, 0.5, 1.0)) -> dict:
    """Detection rate at fixed sizes: fractions of the lower end of each effect's realistic range."""
    from fixtures.world.draw import RANGES

    out = {}
    for name, sensor, design in EFFECTS:
        lo = RANGES[(name, sensor)][0]
        if name == "earth_rotation":
            continue
        rates = {}
        for frac in fractions:
            found = 0
            for seed in range(n):
                session, (effect,) = session_for([(name, sensor)], 30_000 + seed, magnitude=lo * frac, **design)
                rep = blind(session)
                found += any((f["effect"], f["sensor"]) == (name, sensor) for f in rep["findings"])
            rates[f"{lo * frac:.4g}"] = found / n
        out[f"{name}:{sensor}"] = rates
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--clean", type=int, default=100)
    ap.add_argument("--per-effect", type=int, default=20)
    ap.add_argument("--sweep", type=int, default=0, help="seeds per size in the size sweep (0: skip)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    result = {"benchmark": "discrepancy", "timing": timing(), "clean": false_claims(args.clean),
              "effects": detection(args.per_effect)}
    result["two_effects"] = two_effects(max(args.per_effect // 2, 1))
    if args.sweep:
        result["detection_by_size"] = size_sweep(args.sweep)
    red = [v["median_heldout_reduction"] for v in result["effects"].values() if v["median_heldout_reduction"] is not None]
    result["median_heldout_reduction_over_effects"] = statistics.median(red) if red else None
    result["wall_s"] = time.perf_counter() - t0
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
