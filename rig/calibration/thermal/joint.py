"""The temperature model fitted in one piece to the hold means of every temperature step (accelerometer,
magnetometer: a sensor whose holds see a known reference).

The two-stage model (model.py) fits each step's calibration, then the curves through them. Here the curves'
coefficients are fitted to the raw hold means directly, extending the joint estimator's model
(turntable/joint.py) across temperature:

    y_kj = H(T_k)^-1 R_j' v + B(T_k) + e_kj,      e_kj ~ N(0, diag(sigma_kj^2)),   |v| = norm,

k the step, j the hold, B(T) and H(T) the polynomials of model.py with the orders the two-stage fit chose,
v the reference in the world frame (one direction for the whole session). Start: the two-stage model and the
steps' mean fitted direction; then Levenberg-Marquardt (scipy `least_squares(method="lm")`) with the analytic
Jacobian, and the coefficients' covariance (J'J)^-1, scaled by the reduced chi-square where that exceeds 1.
The die temperatures are taken as given (their spread is not propagated here).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.thermal.curves import TermCurves
from rig.calibration.thermal.model import ThermalModel, ThermalStep, fit_thermal_model
from rig.calibration.turntable.joint import calibrate_joint, hold_sigma
from rig.calibration.turntable.observability import tangent_basis


@dataclass
class ThermalHolds:
    """One temperature step's hold means: y (n, 3) raw, the table rotations R (n, 3, 3), the samples' standard
    deviation per hold and axis and the sample counts, and the die temperature."""

    temp_c: float
    y_means: np.ndarray
    R: np.ndarray
    y_std: np.ndarray
    counts: np.ndarray
    temp_std_c: float = 0.0


def fit_thermal_model_joint(sensor: str, holds: list[ThermalHolds], norm: float) -> ThermalModel:
    """The joint fit (module docstring); each step is first calibrated by the joint estimator, for the start
    and for the orders."""
    cals = [calibrate_joint(h.y_means, h.R, norm, y_std=h.y_std, counts=h.counts) for h in holds]
    start = fit_thermal_model(sensor, [ThermalStep(h.temp_c, c, h.temp_std_c) for h, c in zip(holds, cals)])
    v0 = np.mean([np.asarray(c.extra["reference_world"], dtype=float) for c in cals], axis=0)
    v0 = norm * v0 / np.linalg.norm(v0)
    E = tangent_basis(v0) * norm
    dts = [h.temp_c - start.reference_c for h in holds]
    AB = [_block(start.B, dt) for dt in dts]
    AH = [_block(start.H, dt) for dt in dts]
    sig = [hold_sigma(h.y_std, h.counts, len(h.y_means)) for h in holds]
    qB, qH = AB[0].shape[1], AH[0].shape[1]

    def unpack(p):
        w = v0 + E @ p[qB + qH:]
        return p[:qB], p[qB:qB + qH], norm * w / np.linalg.norm(w), w

    def residuals(p):
        cB, cH, v, _ = unpack(p)
        out = []
        for h, A_B, A_H, s in zip(holds, AB, AH, sig):
            K = np.linalg.inv((A_H @ cH).reshape(3, 3))
            pred = np.einsum("kji,j->ki", h.R, v) @ K.T + A_B @ cB
            out.append(((h.y_means - pred) / s).ravel())
        return np.concatenate(out)

    def jacobian(p):
        cB, cH, v, w = unpack(p)
        wn = np.linalg.norm(w)
        dv = norm * (np.eye(3) - np.outer(w, w) / wn ** 2) / wn @ E
        blocks = []
        for h, A_B, A_H, s in zip(holds, AB, AH, sig):
            n = len(h.y_means)
            K = np.linalg.inv((A_H @ cH).reshape(3, 3))
            x = np.einsum("kji,j->ki", h.R, v) @ K.T
            J = np.empty((n, 3, qB + qH + 2))
            J[:, :, :qB] = -A_B[None, :, :]
            J[:, :, qB:qB + qH] = np.einsum("ca,kb->kcab", K, x).reshape(n, 3, 9) @ A_H
            J[:, :, qB + qH:] = -np.einsum("ca,kba,bd->kcd", K, h.R, dv)
            blocks.append((J / s[:, :, None]).reshape(3 * n, -1))
        return np.vstack(blocks)

    p0 = np.concatenate([np.concatenate(start.B.coefficients), np.concatenate(start.H.coefficients), np.zeros(2)])
    sol = least_squares(residuals, p0, jac=jacobian, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14)
    cB, cH, _, _ = unpack(sol.x)
    dof = sol.fun.size - p0.size
    reduced = float(2 * sol.cost / dof) if dof > 0 else float("nan")
    cov = np.linalg.inv(sol.jac.T @ sol.jac)
    if dof > 0 and reduced > 1.0:
        cov = cov * reduced
    return ThermalModel(sensor=sensor, reference_c=start.reference_c, valid_c=start.valid_c,
                        B=_curves(start.B, cB, cov[:qB, :qB], reduced),
                        H=_curves(start.H, cH, cov[qB:qB + qH, qB:qB + qH], reduced), steps=len(holds))


def _block(c: TermCurves, dt: float) -> np.ndarray:
    """(terms, coefficients): each term's value at dt as a linear function of all the group's coefficients."""
    return c.jacobian(dt)


def _curves(start: TermCurves, theta: np.ndarray, cov: np.ndarray, reduced: float) -> TermCurves:
    sizes = [p + 1 for p in start.orders]
    return TermCurves(orders=list(start.orders), coefficients=list(np.split(theta, np.cumsum(sizes)[:-1])),
                      covariance=0.5 * (cov + cov.T), order_scores=start.order_scores, reduced_chi2=reduced)
