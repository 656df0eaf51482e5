"""The temperature model on simulated thermal sessions, beside a model told the true orders and the peers; prints JSON.

Each unit (tests/calibration_thermal/thermal_synth.py) is calibrated at 7 temperature steps from -10 to 65 C (the
accelerometer by the joint estimator on simulated hold means, the gyroscope by a Gaussian stand-in with stated
deviations), its temperature model fitted, and its errors taken at the 6 temperatures halfway between steps:
bias (mg / mdps), scale (ppm) and the calibrated output at full reference input (1 g / 100 dps, worst axis).
Figures are RMS over units and held-out temperatures; `*_ratio_to_true_orders` divides ours by the same GLS told
the true curves' orders (what noise alone leaves); `accel_joint_*` the fit in one piece to the same hold means
(thermal/joint.py). Order selection: the share of B terms given order 1 on
linear units, 3 on cubic ones, 0 on units that do not move with temperature.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests" / "calibration_thermal"), str(ROOT / "benchmarks")]

from comparison import campaign, rms  # noqa: E402
from thermal_synth import held_out_temps, make_unit, thermal_steps  # noqa: E402
import stamp  # noqa: E402  (benchmarks/stamp.py)

from rig.calibration.thermal import fit_thermal_model  # noqa: E402

UNITS = {"accel": "mg", "gyro": "mdps"}
WANT = {"linear": 1, "cubic": 3, "flat": 0}


def _order_shares(sensor: str, units: int, seed: int) -> dict[str, float]:
    out = {}
    for shape, want in WANT.items():
        rng = np.random.default_rng(seed)
        B, H = [], []
        for _ in range(units):
            model = fit_thermal_model(sensor, thermal_steps(make_unit(sensor, rng, shape), rng))
            B.extend(model.B.orders)
            H.append(model.H.orders[0])
        out[f"{sensor}_{shape}_B_order_{want}_share"] = round(float(np.mean(np.asarray(B) == want)), 3)
        out[f"{sensor}_{shape}_scale_order_{want}_share"] = round(float(np.mean(np.asarray(H) == want)), 3)
    return out


def _fit_ms(sensor: str, repeat: int, seed: int) -> float:
    rng = np.random.default_rng(seed)
    steps = thermal_steps(make_unit(sensor, rng), rng)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fit_thermal_model(sensor, steps)
        times.append(time.perf_counter() - t0)
    return round(1e3 * float(np.median(times)), 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--units", type=int, default=60, help="simulated units per sensor (default 60)")
    parser.add_argument("--seed", type=int, default=2026)
    stamp.add_save_option(parser)
    args = parser.parse_args()
    run = stamp.start("bench_thermal_model")
    figures, details = {}, {"units_per_sensor": args.units, "seed": args.seed,
                            "held_out_c": held_out_temps().tolist(), "per_temperature": {}}
    for sensor, unit in UNITS.items():
        c = campaign(sensor, args.units, args.seed, with_joint=True)
        overall = {m: rms(c[m], (0, 1)) for m in c}
        for m in c:
            figures[f"{sensor}_{m}_bias_{unit}"] = round(float(overall[m][0]), 4)
            figures[f"{sensor}_{m}_scale_ppm"] = round(float(overall[m][1]), 1)
            figures[f"{sensor}_{m}_output_{unit}"] = round(float(overall[m][2]), 4)
        for i, what in enumerate(("bias", "scale", "output")):
            ratio = overall["ours"][i] / overall["true_orders"][i]
            figures[f"{sensor}_{what}_ratio_to_true_orders"] = round(float(ratio), 3)
        per_t = {m: rms(c[m], 0) for m in c}
        figures[f"{sensor}_better_than_peers_output_every_held_out_temperature"] = bool(all(
            np.all(per_t["ours"][:, 2] < per_t[p][:, 2]) for p in ("px4", "ardupilot")))
        figures[f"{sensor}_better_than_peers_bias_every_held_out_temperature"] = bool(all(
            np.all(per_t["ours"][:, 0] < per_t[p][:, 0]) for p in ("px4", "ardupilot")))
        details["per_temperature"][sensor] = {m: {"bias": per_t[m][:, 0].round(4).tolist(),
                                                  "scale_ppm": per_t[m][:, 1].round(1).tolist(),
                                                  "output": per_t[m][:, 2].round(4).tolist()} for m in c}
        details.update(_order_shares(sensor, max(10, args.units // 3), args.seed + 1))
        figures[f"{sensor}_fit_ms"] = _fit_ms(sensor, 20, args.seed)
    stamp.report(run, figures=figures, details=details, save=args.save)


if __name__ == "__main__":
    main()
