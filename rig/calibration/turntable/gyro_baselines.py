"""Batch optimizer for the gyro H: the baseline the paper compares its UKF against (eq. 43).

Cost: sum over moves of |Log(R_known^T Int(H (y - B)))|^2, minimised over the nine entries of H by
scipy's trust-region reflective least squares. The Jacobian is a forward difference whose ten
integrations (H and nine perturbations) run as one vectorised call.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.turntable.gyro import MoveSet, gyro_result, rotation_residuals, start_and_scale
from rig.calibration.numerics.result import TriadCalibration
from rig.session_data import MoveStream


def calibrate_gyro_trust_region(moves: list[MoveStream], B: np.ndarray, *, H0: np.ndarray | None = None,
                                max_nfev: int | None = None, step: float = 1e-7) -> TriadCalibration:
    """Gyro H by least_squares(method="trf") on the stacked rotation residuals (eq. 43).

    The covariance is the Gauss-Newton one, sigma^2 (J^T J)^-1 with sigma^2 from the residuals.
    """
    ms = MoveSet.build(moves, B)
    H0, s = start_and_scale(moves, B, H0, "calibrate_gyro_trust_region")

    def fun(x: np.ndarray) -> np.ndarray:
        return rotation_residuals(x.reshape(3, 3) * s, ms).ravel()

    def jac(x: np.ndarray) -> np.ndarray:
        X = np.vstack([x, x + step * np.eye(9)])
        r = rotation_residuals(X.reshape(-1, 3, 3) * s, ms).reshape(10, -1)
        return ((r[1:] - r[0]) / step).T

    res = least_squares(fun, H0.ravel() / s, jac=jac, method="trf", x_scale=1.0, max_nfev=max_nfev,
                        xtol=1e-14, ftol=1e-14, gtol=1e-14)
    H = res.x.reshape(3, 3) * s
    dof = max(res.fun.size - 9, 1)
    sigma2 = float(res.fun @ res.fun) / dof
    try:
        cov = np.linalg.inv(res.jac.T @ res.jac) * sigma2 * s * s
    except np.linalg.LinAlgError:
        cov = np.full((9, 9), np.nan)
    return gyro_result(H, B, ms, cov, "gyro-trust-region", int(res.nfev), bool(res.status > 0),
                   {"moves": len(ms.steps), "optimizer_status": int(res.status)})
