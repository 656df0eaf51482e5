"""How much more accurate the joint estimator is than the two-step method with 12 orientations; prints JSON.

Target (issue 4): "with 12 orientations, the joint estimator at least 3 times more accurate than the two-step
method". Accuracy is not one number, so every statistic is printed and none is picked: for each trial the B
error |dB|, the relative H error ||dH||_F / ||H||_F and the calibrated-vector error (RMS over 2000 directions of
|H_est (y - B_est) - u| / |u|, what a user of the calibration sees), then the gain two-step / joint as the
ratio of RMS errors (the usual "accuracy" of a Monte Carlo), of mean errors and of median errors.

Setups: the paper's Table I Monte Carlo (reconstructed truth, noise variance 0.1 counts^2) with 12 random
orientations, the same with 12 planned orientations (a Fibonacci sphere with a random azimuth, as `rig plan`
makes), and 20 random orientations for contrast.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from procedures.paper_table1 import B_A, G, H_A, NOISE_VARIANCE  # noqa: E402
from procedures.planning import plan_orientations, schedule_rotations  # noqa: E402
from rig.calibration.joint import calibrate_joint  # noqa: E402
from rig.calibration.twostep import calibrate_two_step  # noqa: E402
from rig.errors import CalibrationError  # noqa: E402

TRIALS = 1000


def _directions(rng: np.random.Generator, n: int = 2000) -> np.ndarray:
    d = rng.standard_normal((n, 3))
    return G * d / np.linalg.norm(d, axis=1, keepdims=True)


def _errors(cal, U: np.ndarray, Y: np.ndarray) -> tuple[float, float, float]:
    vec = np.sqrt(np.mean(np.sum(((Y - cal.B) @ cal.H.T - U) ** 2, axis=1))) / G
    return float(np.linalg.norm(cal.B - B_A)), float(np.linalg.norm(cal.H - H_A) / np.linalg.norm(H_A)), float(vec)


def _rotations(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    if kind == "random":
        return Rotation.random(n, random_state=rng).as_matrix()
    yaw = Rotation.from_euler("z", rng.uniform(0, 360), degrees=True).as_matrix()
    return yaw @ schedule_rotations(plan_orientations(n, seed=int(rng.integers(1 << 31))))


def run(kind: str, n: int, trials: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    U = _directions(rng)
    Y = U @ np.linalg.inv(H_A).T + B_A
    rows, failures = [], {"two_step": 0, "joint": 0}
    sigma = np.sqrt(NOISE_VARIANCE)
    for _ in range(trials):
        R = _rotations(kind, n, rng)
        y = np.einsum("kji,j->ki", R, [0.0, 0.0, G]) @ np.linalg.inv(H_A).T + B_A
        y += sigma * rng.standard_normal(y.shape)
        try:
            two = calibrate_two_step(y, R, G)
        except CalibrationError:
            failures["two_step"] += 1
            continue
        try:
            joint = calibrate_joint(y, R, G, y_std=np.full(y.shape, sigma))
        except CalibrationError:
            failures["joint"] += 1
            continue
        rows.append(_errors(two, U, Y) + _errors(joint, U, Y))
    e = np.array(rows)
    two, joint = e[:, :3], e[:, 3:]
    out = {"orientations": n, "schedule": kind, "trials": len(e), "refused": failures}
    for stat, f in (("rms", lambda a: np.sqrt(np.mean(a ** 2, axis=0))), ("mean", lambda a: a.mean(axis=0)),
                    ("median", lambda a: np.median(a, axis=0))):
        g = f(two) / f(joint)
        out[f"gain_{stat}"] = {"B": round(float(g[0]), 2), "H": round(float(g[1]), 2), "vector": round(float(g[2]), 2)}
    out["two_step_rms"] = {"B_counts": float(np.sqrt(np.mean(two[:, 0] ** 2))), "H_rel": float(np.sqrt(np.mean(two[:, 1] ** 2))),
                           "vector_rel": float(np.sqrt(np.mean(two[:, 2] ** 2)))}
    out["joint_rms"] = {"B_counts": float(np.sqrt(np.mean(joint[:, 0] ** 2))), "H_rel": float(np.sqrt(np.mean(joint[:, 1] ** 2))),
                        "vector_rel": float(np.sqrt(np.mean(joint[:, 2] ** 2)))}
    out["share_of_trials_joint_3x_better_vector"] = round(float(np.mean(two[:, 2] >= 3 * joint[:, 2])), 3)
    return out


def main() -> None:
    trials = int(sys.argv[1]) if len(sys.argv) > 1 else TRIALS
    print(json.dumps({"target": "joint >= 3x more accurate than two-step with 12 orientations",
                      "noise_variance_counts2": NOISE_VARIANCE,
                      "cases": [run("random", 12, trials, 0), run("planned", 12, trials, 1), run("random", 20, trials, 2)]},
                     indent=1))


if __name__ == "__main__":
    main()
