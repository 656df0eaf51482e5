"""Mikov, Reginya and Moschevikin's calibration (ICINS 2020, "In-situ gyroscope calibration based on accelerometer
data"; github.com/mikoff/imu-calib, MIT) run as itself on its own MPU-9150 recordings: its own code from a
checkout, called as its `calibrate_real_imu.py` calls it (standstill flags from its detector, the accelerometer
fit, then the gyro's with the accelerometer calibrated), with the parameters kept to full precision; and those
parameters as rig's `u = H (y - B)`.

Usage: python benchmarks/mikov_peer.py --repo DIR [--out JSON]
  runs it on every DIR/data/imu*.log (about 30 s each) and prints (or writes) {file: parameters} as JSON;
  `tests/data/mikoff-imu-calib/peer_params.json` was written so.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np


def run(repo: Path, log: Path) -> dict:
    """Its `calibrate_real_imu.py` without the plots: accelerometer theta (S_X S_Y S_Z NO_X NO_Y NO_Z B_X B_Y
    B_Z), gyro theta (the same, then E_X E_Y E_Z), in the file's units (m/s^2, rad/s)."""
    sys.path.insert(0, str(repo))
    sys.modules.pop("code", None)                 # its package is named `code`, as is a module of the stdlib
    from code.cost_functions import residual_acc, residual_gyr
    from code.helpers import calibrate_accelerometer, find_calib_params_acc, find_calib_params_gyr
    from code.utilities import generate_standstill_flags

    t0 = time.perf_counter()
    imu_data = np.genfromtxt(log, delimiter=" ")
    standstill = generate_standstill_flags(imu_data)
    accs, angs = imu_data[:, 0:3], imu_data[:, 3:6]
    theta_acc = find_calib_params_acc(True, residual_acc, np.zeros(9), accs, standstill > 0)
    theta_gyr = np.zeros(12)
    theta_gyr[-6:-3] = np.mean(angs[0:100, :], axis=0)
    theta_gyr = find_calib_params_gyr(True, residual_gyr, theta_gyr, angs, calibrate_accelerometer(accs, theta_acc),
                                      standstill, 1.0 / 100)
    return {"accel": theta_acc.tolist(), "gyro": theta_gyr.tolist(), "seconds": round(time.perf_counter() - t0, 1)}


def as_rig(params: dict) -> dict:
    """Its `a = M^-1 (y - b)` and `w = M^-1 R (y) - M^-1 b` with `R = (I + [eps]x)^-1` (its eqs. 7 and 8,
    `code/imu_model.py`) as B and H of `u = H (y - B)`: H = M^-1 R, B = R^-1 b."""
    out = {}
    for sensor, theta in (("accel", params["accel"]), ("gyro", params["gyro"])):
        kx, ky, kz, nox, noy, noz, bx, by, bz = theta[:9]
        M = np.array([[1.0 + kx, noy, noz], [0.0, 1.0 + ky, nox], [0.0, 0.0, 1.0 + kz]])
        eps = np.array(theta[9:12]) if sensor == "gyro" else np.zeros(3)
        R_inv = np.eye(3) + np.array([[0.0, -eps[2], eps[1]], [eps[2], 0.0, -eps[0]], [-eps[1], eps[0], 0.0]])
        out[sensor] = {"H": (np.linalg.inv(M) @ np.linalg.inv(R_inv)).tolist(),
                       "B": (R_inv @ np.array([bx, by, bz])).tolist()}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repo", type=Path, required=True, help="a checkout of github.com/mikoff/imu-calib")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    doc = {log.name: run(args.repo, log) for log in sorted((args.repo / "data").glob("imu*.log"))}
    text = json.dumps(doc, indent=1) + "\n"
    if args.out:
        args.out.write_text(text)
    else:
        print(text, end="")


if __name__ == "__main__":
    main()
