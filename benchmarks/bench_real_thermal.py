"""The warm-up fit (rig/noise/thermal_warmup.py) held out, beside PX4's and ArduPilot's offset fits; prints JSON.

No public warming log with a licence that allows copying it into the repository was found (docs/guides/
temperature.md, "Real data"), so the logs are simulated (tests/calibration_thermal/warmup_synth.py): a board still
for 40 min at 50 Hz while its die warms from a -5..10 C soak by 25..40 C, each axis's bias a flat, linear or cubic
curve of realistic size, the world's white noise and a Gauss-Markov bias instability, a thermometer with noise
rounded to 1/340 C. Each log is cut into 16 temperature bands; every other interior band is left out, each method
fitted to the rest and judged on the left-out bands' means.

Figures per sensor and curve: RMS held-out error of ours, PX4's and ArduPilot's (counts: gyro 14.375 / (deg/s),
accel 345 / g), the floor (RMS of the left-out bands' own deviations: what a perfect model would show),
`*_ours_over_floor`, `*_peer_over_ours` (the better peer's RMS over ours), the share of logs on which ours is the
lowest, the mean squared standardised error (1 when the stated deviations are right), the share of axes given
each order on the whole log, and the wall time of one log's held-out comparison. `rig noise` on one simulated
log gives the white noise and bias instability the floor comes from.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "calibration_thermal"), str(ROOT / "benchmarks")]

from warmup_synth import campaign, warmup_log  # noqa: E402
import stamp  # noqa: E402  (benchmarks/stamp.py)

from rig.noise.analysis import analyse_still  # noqa: E402

SENSORS = ("gyro", "accel")
SHAPES = ("flat", "linear", "cubic")
METHODS = ("ours", "px4", "ardupilot")


def _figures(sensor: str, shape: str, runs: list[dict]) -> dict:
    key = f"{sensor}_{shape}"
    mse = {m: np.array([np.mean(r["held"].errors[m] ** 2) for r in runs]) for m in METHODS}
    floor = np.array([np.mean(r["held"].floor ** 2) for r in runs])
    rms = {m: float(np.sqrt(v.mean())) for m, v in mse.items()}
    z = np.concatenate([r["held"].standardised().ravel() for r in runs])
    orders = np.array([r["fit"].curves.orders for r in runs]).ravel()
    best_peer = min(rms["px4"], rms["ardupilot"])
    out = {f"{key}_{m}_rms_counts": round(rms[m], 5) for m in METHODS}
    out.update({f"{key}_floor_rms_counts": round(float(np.sqrt(floor.mean())), 5),
                f"{key}_ours_over_floor": round(rms["ours"] / float(np.sqrt(floor.mean())), 3),
                f"{key}_peer_over_ours": round(best_peer / rms["ours"], 3),
                f"{key}_ours_lowest_share": round(float(np.mean((mse["ours"] <= mse["px4"])
                                                                 & (mse["ours"] <= mse["ardupilot"]))), 3),
                f"{key}_mean_z2": round(float(np.mean(z ** 2)), 3)})
    for p in range(4):
        out[f"{key}_order{p}_share"] = round(float(np.mean(orders == p)), 3)
    return out


def _noise(seed: int) -> dict:
    """`rig noise`'s analysis of one simulated flat warming log's gyroscope (white noise, bias instability)."""
    log = warmup_log(np.random.default_rng(seed), "gyro", "flat")
    report = analyse_still(log.session)
    return {axis: {k: report["sensors"]["gyro"][axis][k] for k in ("N", "N_std", "B", "B_std", "K", "K_std", "Q")}
            for axis in "xyz"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=10, help="simulated logs per sensor and curve")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--save", action="store_true", help="append the result to benchmarks/results/")
    args = ap.parse_args()
    run = stamp.start("bench_real_thermal")
    figures, details = {"logs_per_case": args.logs, "real_logs_found": 0}, {}
    walls = []
    for i, sensor in enumerate(SENSORS):
        for j, shape in enumerate(SHAPES):
            t0 = time.perf_counter()
            runs = campaign(sensor, shape, args.logs, args.seed + 10 * i + j)
            walls.append((time.perf_counter() - t0) / args.logs)
            figures.update(_figures(sensor, shape, runs))
            skipped = [r["held"].skipped for r in runs if r["held"].skipped]
            if skipped:
                details[f"{sensor}_{shape}_skipped"] = skipped
    figures["log_simulate_and_compare_s"] = round(float(np.median(walls)), 2)
    details["rig_noise_gyro_flat_log_counts"] = _noise(args.seed)
    stamp.report(run, figures, details, save=args.save)


if __name__ == "__main__":
    main()
