"""Thermal hysteresis and thermal lag named blind on simulated thermal sessions; prints JSON.

Each session (tests/discrepancy/thermal_sweeps.py) sweeps a simulated unit (tests/calibration_thermal/
thermal_synth.py: cubic bias and scale curves; the accelerometer calibrated per step by the joint estimator, the
gyroscope by its Gaussian stand-in) up through 7 set points from -10 to 65 C and back down through 6, each step
with its own die-temperature rate. Cases per sensor: clean; hysteresis alone (bias half-width drawn from 20-50
mdps or 0.5-1 mg); lag alone (30-120 s); both; on ramped sessions (rates 0.2-2 C/min per step) and on soaked ones
(0.01-0.08 C/min). Figures per case: the share of sessions where exactly the injected causes are named
(`exact`), the share where a cause not injected is named (`false`), the share reported as not distinguishable,
the largest and the median relative size error of each cause named, and the standardised errors' RMS (1 where
the stated deviations are honest).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import stamp  # noqa: E402  (benchmarks/stamp.py)
from tests.calibration_thermal.thermal_synth import MDPS, MG  # noqa: E402
from tests.discrepancy.thermal_sweeps import injected, swept_session  # noqa: E402

from rig.discrepancy.thermal import thermal_causes  # noqa: E402
from rig.effects import THERMAL_HYSTERESIS, THERMAL_LAG  # noqa: E402

SIZES = {"gyro": (20.0, 50.0), "accel": (0.5, 1.0)}
TAU_S = (30.0, 120.0)
CASES = {"clean": (False, False), "hysteresis": (True, False), "lag": (False, True), "both": (True, True)}


def _small(sensor: str, magnitude: float) -> float:
    return magnitude * np.pi / 180 / MDPS if sensor == "gyro" else magnitude / MG


def run_case(sensor: str, case: str, ramped: bool, sessions: int, seed: int) -> dict:
    hysteresis, lag = CASES[case]
    want = {n for n, on in ((THERMAL_HYSTERESIS, hysteresis), (THERMAL_LAG, lag)) if on}
    exact = false = undistinguished = 0
    errors: dict[str, list[float]] = {THERMAL_HYSTERESIS: [], THERMAL_LAG: []}
    z: list[float] = []
    started = time.perf_counter()
    for i in range(sessions):
        rng = np.random.default_rng([seed, i, int(ramped), list(CASES).index(case), int(sensor == "gyro")])
        hidden = injected(rng, bias=rng.uniform(*SIZES[sensor]) if hysteresis else 0.0,
                          tau_s=rng.uniform(*TAU_S) if lag else 0.0)
        causes = thermal_causes(sensor, swept_session(sensor, rng, hidden, ramped=ramped))
        exact += causes.named == want
        false += bool(causes.named - want)
        undistinguished += bool(causes.undistinguished)
        for f in causes.findings:
            if f.effect == THERMAL_HYSTERESIS and hysteresis:
                truth, size, std = hidden.bias_magnitude, _small(sensor, f.magnitude), _small(sensor, f.uncertainty)
            elif f.effect == THERMAL_LAG and lag:
                truth, size, std = hidden.tau_s, f.magnitude, f.uncertainty
            else:
                continue
            errors[f.effect].append(abs(size / truth - 1))
            z.append((size - truth) / std)
    out = {"sessions": sessions, "exact_share": exact / sessions, "false_share": false / sessions,
           "undistinguished_share": undistinguished / sessions,
           "seconds_per_session": (time.perf_counter() - started) / sessions}
    for name, errs in errors.items():
        if errs:
            out[f"{name}_relerr_max"] = float(np.max(errs))
            out[f"{name}_relerr_median"] = float(np.median(errs))
            out[f"{name}_within_40pct_share"] = float(np.mean(np.asarray(errs) <= 0.4))
    if z:
        out["z_rms"] = float(np.sqrt(np.mean(np.square(z))))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=40, help="simulated sessions per case (default 40)")
    parser.add_argument("--seed", type=int, default=2026)
    stamp.add_save_option(parser)
    args = parser.parse_args()
    run = stamp.start("bench_thermal_causes")
    details: dict = {}
    figures: dict = {}
    for sensor in ("gyro", "accel"):
        for ramped in (True, False):
            for case in CASES:
                key = f"{sensor}_{'ramped' if ramped else 'soaked'}_{case}"
                r = run_case(sensor, case, ramped, args.sessions, args.seed)
                details[key] = r
                figures[f"{key}_exact_share"] = r["exact_share"]
                if case == "clean":
                    figures[f"{key}_called_share"] = r["false_share"] + r["undistinguished_share"]
                for name in (THERMAL_HYSTERESIS, THERMAL_LAG):
                    if f"{name}_relerr_max" in r:
                        figures[f"{key}_{name}_relerr_max"] = round(r[f"{name}_relerr_max"], 4)
    stamp.report(run, figures=figures, details={"cases": details, "sessions_per_case": args.sessions,
                                                "seed": args.seed}, save=args.save)


if __name__ == "__main__":
    main()
