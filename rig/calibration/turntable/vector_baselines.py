"""The comparisons of Zhang et al. 2015 on the same inputs as the two-step method.

* `calibrate_sqp`: a general constrained optimiser (scipy SLSQP) on the vector cost (eq. 25 as numbered in
  the project brief; reconstructed, the paper's text was not available)
      min_{B, H, v}  sum_k |H (y_k - B) - R_k^T v|^2   subject to |v| = norm,
  i.e. the same model the two-step method solves, without its structure.
* `calibrate_sensor_frame_only`: the ellipsoid alone (what ArduPilot/PX4/Magneto do): H = norm * A^(1/2),
  symmetric, so a mounting rotation between sensor and fixture can never be recovered.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from rig.calibration.numerics.ellipsoid import fit_ellipsoid, sphere_map
from rig.calibration.turntable.observability import require_spread, validate_holds
from rig.calibration.numerics.result import TriadCalibration

MIN_ORIENTATIONS = 9


def calibrate_sqp(y_means: np.ndarray, R: np.ndarray, norm: float, *, max_iter: int = 200, tol: float = 1e-14,
                  record_history: bool = False, full_scale: float | None = None) -> TriadCalibration:
    """SLSQP on the reconstructed eq. 25 cost; naive start (B = mean of y, H = isotropic scale).

    Parameters are scaled internally (B in units of the reading spread, H relative to the start scale) so
    SLSQP sees O(1) variables. extra["history"] holds (B, H) after every SLSQP iteration when asked.
    residual_rms: RMS of |u_k - R_k^T v|.
    """
    y, R = validate_holds(y_means, R, min_orientations=MIN_ORIENTATIONS, full_scale=full_scale, what="sqp")
    require_spread(y, "sqp")
    n = len(y)
    B0 = y.mean(axis=0)
    spread = float(np.mean(np.linalg.norm(y - B0, axis=1)))
    h0 = norm / spread
    v0 = np.einsum("kab,kb->a", R, (y - B0) * h0) / n
    v0 = v0 / np.linalg.norm(v0) if np.linalg.norm(v0) > 1e-9 else np.array([0.0, 0.0, 1.0])
    yn = (y - B0) / spread                                   # O(1) readings

    def unpack(p):
        return p[0:3], p[3:12].reshape(3, 3), p[12:15]       # b (spread units), Hn (= H spread/norm), w (= v/norm)

    R_rows = R.transpose(0, 2, 1).reshape(3 * n, 3)          # stacked R_k^T: R_k^T w = (R_rows @ w)[k]

    def cost_grad(p):
        b, Hn, w = unpack(p)
        z = yn - b
        r = z @ Hn.T - (R_rows @ w).reshape(n, 3)
        g = np.empty(15)
        g[0:3] = -2 * (r.sum(axis=0) @ Hn)
        g[3:12] = 2 * (r.T @ z).ravel()
        g[12:15] = -2 * (r.ravel() @ R_rows)
        return float(np.dot(r.ravel(), r.ravel())), g

    cons = {"type": "eq", "fun": lambda p: np.array([p[12:15] @ p[12:15] - 1.0]),
            "jac": lambda p: np.concatenate([np.zeros(12), 2 * p[12:15]])[None, :]}
    history: list = []

    def callback(p):
        b, Hn, _ = unpack(p)
        history.append((B0 + spread * b, Hn * norm / spread))

    p0 = np.concatenate([np.zeros(3), np.eye(3).ravel(), v0])
    sol = minimize(cost_grad, p0, jac=True, method="SLSQP", constraints=[cons],
                   callback=callback if record_history else None, options={"maxiter": max_iter, "ftol": tol})
    b, Hn, w = unpack(sol.x)
    B, H, v = B0 + spread * b, Hn * norm / spread, w * norm / np.linalg.norm(w)
    if np.linalg.det(H) < 0:
        H, v = -H, -v
    u = (y - B) @ H.T
    misfit = u - np.einsum("kji,j->ki", R, v)
    warnings = [] if sol.success else [f"sqp: SLSQP did not converge ({sol.message})"]
    extra = {"reference_world": v.tolist(), "residual_kind": "rms |u_k - R_k^T v|",
             "norm_rms": float(np.sqrt(np.mean((np.linalg.norm(u, axis=1) - norm) ** 2)))}
    if record_history:
        signs = np.where(np.linalg.det(np.array([Hk for _, Hk in history])) > 0, 1.0, -1.0) if history else []
        extra["history"] = [(Bk, Hk * s) for (Bk, Hk), s in zip(history, signs)]
    return TriadCalibration(B=B, H=H, method="sqp", residual_rms=float(np.sqrt(np.mean(np.sum(misfit**2, axis=1)))),
                            iterations=int(sol.nit), converged=bool(sol.success), warnings=warnings, extra=extra)


def calibrate_sensor_frame_only(y_means: np.ndarray, norm: float, *, full_scale: float | None = None) -> TriadCalibration:
    """Ellipsoid only: B = centre, H = norm * sqrtm(A) (symmetric). residual_rms: RMS of |u_k| - norm."""
    y, _ = validate_holds(y_means, None, min_orientations=MIN_ORIENTATIONS, full_scale=full_scale,
                          what="sensor-frame")
    fit = fit_ellipsoid(y, what="sensor-frame")
    H = sphere_map(fit, norm)
    u = (y - fit.center) @ H.T
    return TriadCalibration(B=fit.center, H=H, method="sensor-frame",
                            residual_rms=float(np.sqrt(np.mean((np.linalg.norm(u, axis=1) - norm) ** 2))),
                            iterations=1, converged=True,
                            warnings=["sensor-frame: mounting rotation not calibrated (H is symmetric by construction)"],
                            extra={"residual_kind": "rms |u_k| - norm"})
