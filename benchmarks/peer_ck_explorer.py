"""CK-Explorer's accelerometer and magnetometer calibration (github.com/CK-Explorer/Magnetometer-and-Accelerometer-
Calibration, Apache-2.0; its `Working Principle/Working Principle.pdf`) reproduced from its published method on its
own two example logs, `tests/data/ck-explorer-accmag/acc_log.csv` and `acc_mag_log.csv`. The repository publishes
the method and the logs but no numbers from them, so this is the authors' result the tests compare rig with.

Its method, section by section of the PDF:
  2. an algebraic ellipsoid fit of the samples (eq. 8; its scripts call Petrov's `ellipsoid_fit_new`, whose
     default is the least-squares quadric with v0 + v1 + v2 = 3), the centre from the quadric, kappa (eq. 11),
     L^T L = M / kappa (eq. 12) and the lower-triangular L of eq. 13; the calibrated, normalised reading is
     L (y - centre) (eq. 14).
  3. for the magnetometer beside an accelerometer, the rotation R_mis (a unit quaternion through the
     stereographic projection of eqs. 18-24, started at the identity) and beta = cos(theta) that minimise
     sum (a^T R_mis m - |a| |m| beta)^2 (eq. 16) by Levenberg-Marquardt, started at beta = 0 as its examples are.

Usage: python benchmarks/peer_ck_explorer.py [--out tests/data/ck-explorer-accmag/peer_params.json]
  prints the benchmark JSON (the parameters, the norm and dip scatters they give, the run time).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "ck-explorer-accmag"


def ellipsoid_quadric(y: np.ndarray) -> np.ndarray:
    """The quadric v (eq. 8) minimising sum Q(y_i)^2 with v0 + v1 + v2 = 3: Q = |y|^2 - D u, where D's columns
    span the quadrics whose squared terms sum to zero, solved by linear least squares."""
    x1, x2, x3 = y[:, 0], y[:, 1], y[:, 2]
    D = np.column_stack([x1 * x1 + x2 * x2 - 2 * x3 * x3, x1 * x1 + x3 * x3 - 2 * x2 * x2, 2 * x1 * x2, 2 * x1 * x3,
                         2 * x2 * x3, 2 * x1, 2 * x2, 2 * x3, np.ones(len(y))])
    u, *_ = np.linalg.lstsq(D, (y * y).sum(axis=1), rcond=None)
    v = np.empty(10)
    v[0] = 1 - u[0] - u[1]
    v[1] = 1 - u[0] + 2 * u[1]
    v[2] = 1 + 2 * u[0] - u[1]
    v[3:9] = -u[2:8]
    v[9] = -u[8]
    return v


def section2(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre and the lower-triangular L of eqs. 11-13, so that L (y - centre) lies on the unit sphere."""
    v = ellipsoid_quadric(y)
    M = np.array([[v[0], v[3], v[4]], [v[3], v[1], v[5]], [v[4], v[5], v[2]]])
    centre = np.linalg.solve(M, -v[6:9])
    kappa = centre @ M @ centre - v[9]
    A, B, C, D, E, F = np.array([v[0], v[1], v[2], v[3], v[4], v[5]]) / kappa
    f = np.sqrt(C)
    e, g = F / f, E / f
    c = np.sqrt(B - e * e)
    b = (D - e * g) / c
    a = np.sqrt(A - b * b - g * g)
    return centre, np.array([[a, 0.0, 0.0], [b, c, 0.0], [g, e, f]])


def quaternion_from_stereographic(X: float, Y: float, Z: float) -> np.ndarray:
    """Eqs. 21-24."""
    s = 1 + X * X + Y * Y + Z * Z
    return np.array([2 * X / s, (X * X + Y * Y + Z * Z - 1) / s, 2 * Y / s, 2 * Z / s])


def rotation(q: np.ndarray) -> np.ndarray:
    """Eq. 17."""
    q0, q1, q2, q3 = q
    return np.array([[1 - 2 * q2 * q2 - 2 * q3 * q3, 2 * q1 * q2 - 2 * q0 * q3, 2 * q1 * q3 + 2 * q0 * q2],
                     [2 * q1 * q2 + 2 * q0 * q3, 1 - 2 * q1 * q1 - 2 * q3 * q3, 2 * q2 * q3 - 2 * q0 * q1],
                     [2 * q1 * q3 - 2 * q0 * q2, 2 * q2 * q3 + 2 * q0 * q1, 1 - 2 * q1 * q1 - 2 * q2 * q2]])


def section3(accel: np.ndarray, mag_normalised: np.ndarray, beta0: float = 0.0) -> tuple[np.ndarray, float]:
    """R_mis and beta of eq. 16, from q = [1, 0, 0, 0] (X = 1, Y = Z = 0 by eq. 18) and beta0."""
    norms = np.linalg.norm(accel, axis=1) * np.linalg.norm(mag_normalised, axis=1)

    def residual(p: np.ndarray) -> np.ndarray:
        R = rotation(quaternion_from_stereographic(*p[:3]))
        return np.einsum("ij,ij->i", accel, mag_normalised @ R.T) - norms * p[3]

    fit = least_squares(residual, np.array([1.0, 0.0, 0.0, beta0]), method="lm")
    return rotation(quaternion_from_stereographic(*fit.x[:3])), float(fit.x[3])


def relative_norm_scatter(u: np.ndarray) -> float:
    n = np.linalg.norm(u, axis=1)
    return float(n.std() / n.mean())


def dip_scatter_deg(accel: np.ndarray, field: np.ndarray) -> float:
    """Standard deviation of the angle between the specific force and the field, sample by sample."""
    cos = np.einsum("ij,ij->i", accel, field) / (np.linalg.norm(accel, axis=1) * np.linalg.norm(field, axis=1))
    return float(np.degrees(np.arccos(np.clip(cos, -1, 1))).std())


def as_rig(centre: np.ndarray, L: np.ndarray, R: np.ndarray | None = None) -> dict:
    """`u = H (y - B)` with H = R L (eq. 25; eq. 14 without R) and B the centre, in the file's units; the output is
    on the unit sphere (the authors' normalised reading)."""
    H = L if R is None else R @ L
    return {"H": H.tolist(), "B": centre.tolist()}


def run() -> dict:
    acc_only = np.loadtxt(DATA / "acc_log.csv", delimiter=",", skiprows=1)
    t0 = time.perf_counter()
    c_acc, L_acc = section2(acc_only)
    both = np.loadtxt(DATA / "acc_mag_log.csv", delimiter=",", skiprows=1)
    accel, mag = both[:, :3], both[:, 3:]
    c_mag, L_mag = section2(mag)
    m_hat = (mag - c_mag) @ L_mag.T
    R_mis, beta = section3(accel, m_hat)
    seconds = time.perf_counter() - t0
    return {
        "acc_log.csv": {"accel": as_rig(c_acc, L_acc),
                        "accel_norm_scatter": relative_norm_scatter((acc_only - c_acc) @ L_acc.T)},
        "acc_mag_log.csv": {"mag": as_rig(c_mag, L_mag, R_mis), "beta": beta,
                            "dip_deg": float(np.degrees(np.arccos(beta))),
                            "mag_norm_scatter": relative_norm_scatter(m_hat),
                            "dip_scatter_deg": dip_scatter_deg(accel, m_hat @ R_mis.T),
                            "dip_scatter_deg_without_R_mis": dip_scatter_deg(accel, m_hat)},
        "seconds": round(seconds, 3),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="also write the parameters (peer_params.json)")
    args = parser.parse_args()
    result = run()
    if args.out:
        params = {k: v for k, v in result.items() if k != "seconds"}
        params["method"] = "benchmarks/peer_ck_explorer.py (the authors' published method, reproduced)"
        args.out.write_text(json.dumps(params, indent=1) + "\n")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).resolve().parent).stdout.strip()
    print(json.dumps({"benchmark": "peer_ck_explorer", "date": datetime.date.today().isoformat(), "commit": commit,
                      "machine": f"{platform.machine()} {os.cpu_count()} cpu", "load": round(os.getloadavg()[0], 2),
                      **result}, indent=1))


if __name__ == "__main__":
    main()
