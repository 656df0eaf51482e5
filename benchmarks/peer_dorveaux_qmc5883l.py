"""tomisuarez2/MagnetometerCalibration's QMC5883L result (MIT) checked against its published method: Dorveaux,
Vissiere, Martin and Petit, "Iterative calibration method for inertial and magnetic sensors", IEEE CDC 2009,
reproduced here from the paper and run on the two logs of `tests/data/qmc5883l-tomisuarez2`, to say which
published parameters belong to which log and how closely the method gives them back.

The method (the paper's eq. 4 and its iteration; the repository's README and `CalibrationTests/
test_mag_calibration.py` say how it was run): drop the first `Initialization time` seconds (60 s at 50 Hz), take
the mean of the rest off (or, in the version that wrote the filtered log's result, a least-squares sphere's
centre), then repeatedly fit A_k, B_k by linear least squares so that A_k m + B_k is nearest the
unit vector along m, apply it, and stop when the cost falls by less than `tol` relatively (1e-4 in its test);
the product of the steps, composed with the centre taken off, is `u = A m + b`, on the unit sphere.

Usage: python benchmarks/peer_dorveaux_qmc5883l.py
  prints the benchmark JSON: per log, the reproduced parameters, the largest difference from the authors'
  published A and b (relative to their largest element), and the relative field-norm scatter each gives on the
  samples after the rest.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "qmc5883l-tomisuarez2"
RATE_HZ = 50.0
INITIAL_REST_S = 60.0
# the repository's code took the mean off first when it wrote the noisy log's parameters (its head), a least-squares
# sphere's centre when it wrote the filtered log's (commit 9590433, the numbers its README prints)
START = {"noisy_raw_data.csv": "mean", "filtered_raw_data.csv": "sphere"}


def read_log(path: Path) -> np.ndarray:
    """mx, my, mz in counts: two lines of settings and the header above the rows."""
    return np.loadtxt(path, delimiter=",", skiprows=3)


def authors_parameters(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The authors' `u = A m + b` for a log: the 12 numbers (A row by row, then b) of their result file."""
    p = np.loadtxt(DATA / {"noisy_raw_data.csv": "paramters_mag.csv",
                           "filtered_raw_data.csv": "paramters_mag_filtered.csv"}[name])
    return p[:9].reshape(3, 3), p[9:]


def sphere_centre(m: np.ndarray) -> np.ndarray:
    """The centre of the least-squares sphere, from the linear |m|^2 = 2 c . m + k."""
    design = np.column_stack([2 * m, np.ones(len(m))])
    solution, *_ = np.linalg.lstsq(design, (m * m).sum(axis=1), rcond=None)
    return solution[:3]


def dorveaux(m: np.ndarray, start: str, tol: float = 1e-4, max_iterations: int = 5000) -> tuple[np.ndarray, np.ndarray]:
    """`u = A m + b` by the paper's iteration, from the samples' mean (start="mean") or a least-squares sphere's
    centre (start="sphere") taken off."""
    centre = m.mean(axis=0) if start == "mean" else sphere_centre(m)
    current = m - centre
    A_total, b_total = np.eye(3), np.zeros(3)
    previous = None
    for _ in range(max_iterations):
        target = current / np.linalg.norm(current, axis=1, keepdims=True)
        design = np.column_stack([current, np.ones(len(current))])
        step, *_ = np.linalg.lstsq(design, target, rcond=None)
        cost = float(((design @ step - target) ** 2).sum())
        if previous is not None and (previous - cost) / previous < tol:
            break
        previous = cost
        A_k, b_k = step[:3].T, step[3]
        A_total, b_total = A_k @ A_total, A_k @ b_total + b_k
        current = current @ A_k.T + b_k
    return A_total, b_total - A_total @ centre


def relative_norm_scatter(m: np.ndarray, A: np.ndarray, b: np.ndarray) -> float:
    n = np.linalg.norm(m @ A.T + b, axis=1)
    return float(n.std() / n.mean())


def main() -> None:
    results = {}
    for name in ("filtered_raw_data.csv", "noisy_raw_data.csv"):
        m = read_log(DATA / name)[int(INITIAL_REST_S * RATE_HZ):]
        t0 = time.perf_counter()
        A, b = dorveaux(m, START[name])
        seconds = time.perf_counter() - t0
        A_auth, b_auth = authors_parameters(name)
        results[name] = {
            "reproduced": np.concatenate([A.ravel(), b]).tolist(),
            "A_max_difference_relative": float(np.abs(A - A_auth).max() / np.abs(A_auth).max()),
            "b_max_difference_relative": float(np.abs(b - b_auth).max() / np.abs(b_auth).max()),
            "norm_scatter_published": relative_norm_scatter(m, A_auth, b_auth),
            "norm_scatter_reproduced": relative_norm_scatter(m, A, b),
            "centre_published_counts": (-np.linalg.solve(A_auth, b_auth)).tolist(),
            "samples": len(m),
            "seconds": round(seconds, 3),
        }
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).resolve().parent).stdout.strip()
    print(json.dumps({"benchmark": "peer_dorveaux_qmc5883l", "date": datetime.date.today().isoformat(),
                      "commit": commit, "machine": f"{platform.machine()} {os.cpu_count()} cpu",
                      "load": round(os.getloadavg()[0], 2), "logs": results}, indent=1))


if __name__ == "__main__":
    main()
