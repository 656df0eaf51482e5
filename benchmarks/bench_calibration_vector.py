"""Timing of the accelerometer/magnetometer calibration solvers; prints JSON.

Targets (project brief): one two-step accelerometer solve with 20 orientations <= 0.5 ms; SLSQP at equal
accuracy >= 100x slower; the 1000-run Table I in <= 2 s. SLSQP is timed twice: with the analytic gradient
(the fair, fast version) and with finite differences (what a generic optimiser call does by default).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.spatial.transform import Rotation

from procedures.paper_table1 import run_table1
from rig.calibration.turntable.joint import calibrate_joint
from rig.calibration.turntable.twostep import calibrate_two_step
from rig.calibration.turntable.vector_baselines import calibrate_sqp

import stamp  # benchmarks/stamp.py

G = 9.80665


def _median_ms(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def _problem(seed: int, n: int = 20):
    rng = np.random.default_rng(seed)
    R = Rotation.random(n, random_state=rng).as_matrix()
    H_inv = 400 * (np.eye(3) + 0.02 * rng.standard_normal((3, 3)))
    B = rng.uniform(-2000, 2000, 3)
    y = np.einsum("kji,j->ki", R, [0, 0, G]) @ H_inv.T + B + 0.5 * rng.standard_normal((n, 3))
    return y, R, np.linalg.inv(H_inv), B


def _sqp_finite_difference(y, R, ftol: float = 1e-14):
    """SLSQP on the same cost with 2-point gradients (scipy default when no jac is given)."""
    from scipy.optimize import minimize
    B0 = y.mean(axis=0)
    spread = float(np.mean(np.linalg.norm(y - B0, axis=1)))
    yn = (y - B0) / spread

    def cost(p):
        r = (yn - p[:3]) @ p[3:12].reshape(3, 3).T - np.einsum("kji,j->ki", R, p[12:15])
        return float(np.sum(r**2))

    v0 = np.einsum("kab,kb->a", R, yn) / len(y)
    p0 = np.concatenate([np.zeros(3), np.eye(3).ravel(), v0 / np.linalg.norm(v0)])
    return minimize(cost, p0, method="SLSQP", constraints=[{"type": "eq", "fun": lambda p: p[12:15] @ p[12:15] - 1}],
                    options={"maxiter": 200, "ftol": ftol})


def _sqp_fd_H(y, R, ftol: float) -> np.ndarray:
    """H from the finite-difference SLSQP, rescaled to mean |u_k| = G with det(H) > 0 as ours is."""
    res = _sqp_finite_difference(y, R, ftol)
    B0 = y.mean(axis=0)
    spread = float(np.mean(np.linalg.norm(y - B0, axis=1)))
    Hn = res.x[3:12].reshape(3, 3)
    u = (y - (B0 + spread * res.x[:3])) @ Hn.T
    H = Hn * G / np.linalg.norm(u, axis=1).mean()
    return H if np.linalg.det(H) > 0 else -H


FTOL_LADDER = (1e-14, 1e-12, 1e-10, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4)


def equal_accuracy(problems: int = 20) -> dict:
    """The finite-difference SLSQP stopped as early as it can be while its RMS H error over `problems` random
    problems stays at or below the two-step method's: the issue's "at equal accuracy", measured rather than
    assumed (a tight ftol over-solves far below the noise and flatters the speed-up)."""
    cases = [_problem(seed) for seed in range(problems)]
    rms = lambda e: float(np.sqrt(np.mean(np.square(e))))
    ours = rms([np.linalg.norm(calibrate_two_step(y, R, G).H - H) / np.linalg.norm(H) for y, R, H, _ in cases])
    t_ours = float(np.median([_median_ms(lambda: calibrate_two_step(y, R, G), 200) for y, R, _, _ in cases]))
    ladder = []
    for ftol in FTOL_LADDER:
        err = rms([np.linalg.norm(_sqp_fd_H(y, R, ftol) - H) / np.linalg.norm(H) for y, R, H, _ in cases])
        t = float(np.median([_median_ms(lambda: _sqp_finite_difference(y, R, ftol), 5) for y, R, _, _ in cases]))
        ladder.append({"ftol": ftol, "H_rms_error": err, "median_ms": round(t, 3)})
    loosest = ladder[0]
    for row in ladder:
        if row["H_rms_error"] > ours:
            break
        loosest = row
    return {"problems": problems, "two_step_H_rms_error": ours, "two_step_median_ms": round(t_ours, 4),
            "slsqp_fd_ladder": ladder, "slsqp_fd_loosest_ftol_at_equal_accuracy": loosest["ftol"],
            "slsqp_fd_equal_accuracy_ms": loosest["median_ms"],
            "speedup_vs_sqp_finite_difference_equal_accuracy": round(loosest["median_ms"] / t_ours, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    stamp.add_save_option(parser)
    args = parser.parse_args()
    run = stamp.start("bench_calibration_vector")
    y, R, H, B = _problem(0)
    ours = calibrate_two_step(y, R, G)
    sqp = calibrate_sqp(y, R, G)
    t_two = _median_ms(lambda: calibrate_two_step(y, R, G), 2000)
    t_sqp = _median_ms(lambda: calibrate_sqp(y, R, G), 200)
    t_sqp_fd = _median_ms(lambda: _sqp_finite_difference(y, R), 50)
    t_joint = _median_ms(lambda: calibrate_joint(y, R, G, refine_ml=False), 300)
    t_joint_ml = _median_ms(lambda: calibrate_joint(y, R, G), 300)
    t_joint_ml_ref = _median_ms(lambda: calibrate_joint(y, R, G, reference_world=(0, 0, 1)), 300)
    t0 = time.perf_counter()
    table = run_table1(runs=1000, seed=0)
    t_table = time.perf_counter() - t0
    out = {
        "two_step_accel_20_orientations_ms": round(t_two, 4),
        "two_step_iterations": ours.iterations,
        "sqp_slsqp_analytic_gradient_ms": round(t_sqp, 3),
        "sqp_slsqp_finite_difference_ms": round(t_sqp_fd, 3),
        "speedup_vs_sqp_analytic": round(t_sqp / t_two, 1),
        "speedup_vs_sqp_finite_difference": round(t_sqp_fd / t_two, 1),
        "H_rel_error_two_step": float(np.linalg.norm(ours.H - H) / np.linalg.norm(H)),
        "H_rel_error_sqp": float(np.linalg.norm(sqp.H - H) / np.linalg.norm(H)),
        "joint_ls_ms": round(t_joint, 3),
        "joint_ml_ms": round(t_joint_ml, 3),
        "joint_ml_with_reference_start_ms": round(t_joint_ml_ref, 3),
        "table1_1000_runs_s": round(t_table, 3),
        "table1_ours_part_s": round(table["seconds"]["ours"], 3),
        "table1_optimizer_part_s": round(table["seconds"]["optimizer"], 3),
        "equal_accuracy": equal_accuracy(),
        "targets": {"two_step_ms": 0.5, "speedup_vs_sqp": 100, "table1_s": 2.0},
    }
    figures = {key: out[key] for key in ("two_step_accel_20_orientations_ms", "speedup_vs_sqp_analytic",
                                         "joint_ml_ms", "table1_1000_runs_s")}
    stamp.report(run, figures, out, save=args.save)


if __name__ == "__main__":
    main()
