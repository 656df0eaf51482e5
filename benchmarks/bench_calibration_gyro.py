"""Timing and accuracy of the gyro calibration and the turntable-free mode; prints JSON.

Targets (project brief): gyro H by the UKF over 19 moves (20 tumble-table orientations, 100 Hz) in
<= 50 ms median. Also timed: the trust-region baseline on the same moves, the data-driven start
(H0 = None), and the turntable-free calibration of imu_tk's Xsens record, with its numbers next
to imu_tk's (anchors-calibration.md 4.2).
Usage: python benchmarks/bench_calibration_gyro.py [--repeat N]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from procedures.paper_table2 import (NOMINAL_COUNTS_PER_RAD_S, move_angle_noise, random_gyro_truth,  # noqa: E402
                                     simulate_gyro_moves)
from rig.calibration.turntable.gyro import calibrate_gyro, calibrate_gyro_ukf  # noqa: E402
from rig.calibration.turntable.gyro_baselines import calibrate_gyro_trust_region  # noqa: E402
from rig.calibration.numerics.integrate import integrate_rotation  # noqa: E402
from rig.calibration.recordings.turntable_free import calibrate_turntable_free  # noqa: E402

XSENS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "imu_tk-xsens"
IMU_TK = {"accel_bias": [33124.1825646, 33275.1794342, 32364.4156494],
          "accel_inverse_scale": [414.459, 412.010, 414.649],
          "gyro_bias": [32777.139944, 32459.8028788, 32511.847461],
          "gyro_inverse_scale": [4777.96, 4764.21, 4773.66],
          "accel_intervals": 38, "accel_k": 6, "accel_cost": 0.120131, "accel_rms_full_intervals_m_s2": 0.00818,
          "gyro_cost": 1.506956e-3}


def timed(fn, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, {"median_ms": 1e3 * float(np.median(times)), "min_ms": 1e3 * float(np.min(times)), "runs": repeat}


def gyro_cases(repeat: int) -> dict:
    rng = np.random.default_rng(0)
    H, B = random_gyro_truth(rng)
    H0 = np.eye(3) / NOMINAL_COUNTS_PER_RAD_S
    out = {}
    for label, noise in (("clean", 0.0), ("noise_0.005_rad_s", 0.005)):
        moves, _ = simulate_gyro_moves(rng, H, B, orientations=20, noise_rad_s=noise)
        samples = int(sum(len(m.t) for m in moves))
        counts_noise = np.full(3, max(noise * NOMINAL_COUNTS_PER_RAD_S, 1 / np.sqrt(12)))   # what rig calibrate gives
        case = {"moves": len(moves), "samples": samples}
        for name, fn in (("ukf_nominal_H0", lambda: calibrate_gyro_ukf(moves, B, H0=H0)),
                         ("ukf_data_H0", lambda: calibrate_gyro_ukf(moves, B)),
                         ("both_sample_models_data_H0", lambda: calibrate_gyro(moves, B)),
                         ("auto_noise_gated_data_H0", lambda: calibrate_gyro(moves, B, rate_noise_counts=counts_noise)),
                         ("trust_region_nominal_H0", lambda: calibrate_gyro_trust_region(moves, B, H0=H0))):
            cal, t = timed(fn, repeat)
            case[name] = dict(t, rel_err=float(np.linalg.norm(cal.H - H) / np.linalg.norm(H)),
                              iterations=cal.iterations, converged=cal.converged)
        out[label] = case
    m = max(moves, key=lambda mv: len(mv.t))
    w = (m.y - B) @ H.T
    _, t = timed(lambda: integrate_rotation(m.t, w), repeat * 5)
    out["integrate_rotation_one_move"] = dict(t, samples=len(m.t))
    _, t = timed(lambda: integrate_rotation(m.t, np.broadcast_to(w, (19,) + w.shape)), repeat * 5)
    out["integrate_rotation_19_sigma_points"] = dict(t, samples=len(m.t))
    return out


def weighting_case(seeds: int = 40, noise: float = 0.005) -> dict:
    """Duration-weighted UKF measurements against equal weights, on random moves of unequal length."""
    errs = []
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        H, B = random_gyro_truth(rng)
        moves, _ = simulate_gyro_moves(rng, H, B, orientations=20, noise_rad_s=noise)
        nr = move_angle_noise(moves, noise)
        errs.append([np.linalg.norm(calibrate_gyro_ukf(moves, B, noise_rad=nr, weight_by_duration=wb).H - H)
                     / np.linalg.norm(H) for wb in (False, True)])
    e = np.array(errs)
    return {"seeds": seeds, "noise_rad_s": noise, "rms_rel_err_equal_weights": float(np.sqrt(np.mean(e[:, 0] ** 2))),
            "rms_rel_err_duration_weights": float(np.sqrt(np.mean(e[:, 1] ** 2))),
            "duration_weights_better_in": int(np.sum(e[:, 1] < e[:, 0]))}


def xsens_case(repeat: int) -> dict:
    acc, gyr = np.loadtxt(XSENS / "xsens_acc.mat"), np.loadtxt(XSENS / "xsens_gyro.mat")
    cal, t = timed(lambda: calibrate_turntable_free(acc[:, 0], acc[:, 1:], gyr[:, 1:], gravity=9.81744), repeat)
    a, g = cal["accel"], cal["gyro"]
    ours = {"accel_bias": a.B.tolist(), "accel_inverse_scale": (1 / np.diag(a.H)).tolist(),
            "gyro_bias": g.B.tolist(), "gyro_inverse_scale": (1 / np.diag(g.H)).tolist(),
            "accel_intervals": len(a.extra["intervals"]), "accel_k": a.extra["k"], "accel_cost": a.extra["cost"],
            "accel_rms_full_intervals_m_s2": a.extra["residual_rms_full_intervals"], "gyro_cost": g.extra["cost"]}
    pct = lambda key: (100 * (np.array(ours[key]) / np.array(IMU_TK[key]) - 1)).tolist()
    diff = {"accel_bias_counts": (a.B - IMU_TK["accel_bias"]).tolist(),
            "accel_inverse_scale_pct": pct("accel_inverse_scale"), "gyro_inverse_scale_pct": pct("gyro_inverse_scale"),
            "gyro_bias_counts": (g.B - IMU_TK["gyro_bias"]).tolist()}
    return {"time": t, "ours": ours, "imu_tk": IMU_TK, "difference": diff}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    print(json.dumps({"benchmark": "calibration_gyro", "target_ukf_19_moves_median_ms": 50,
                      "gyro": gyro_cases(args.repeat), "move_weighting": weighting_case(),
                      "turntable_free_xsens": xsens_case(max(3, args.repeat // 5))},
                     indent=2))


if __name__ == "__main__":
    main()
