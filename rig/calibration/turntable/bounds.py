"""Cramer-Rao lower bound for B and H of an accelerometer/magnetometer calibrated from known holds.

Model (joint.py): `y_k = K R_k^T v + B + e_k`, `K = H^-1`, `e_k ~ N(0, diag(sigma_k^2))`, independent holds.
The Fisher information is `F = sum_k J_k^T diag(sigma_k^-2) J_k` with `J_k = dy_k / dtheta`, and any unbiased
estimator has covariance >= F^-1. That tells whether an estimator can still improve: if its error is at the
bound, no (unbiased) method can do better with the same holds.

Why this parametrisation (14 numbers): B (3) and K = H^-1 (9) because the readings are linear in them (the
Jacobian is exact, no inverse in it); the direction of v by 2 tangent angles, because |v| = norm is known and
(c K, v / c) predicts the same readings for any c, so a free |v| would make F singular; the direction itself
must be estimated (table not level, unknown dip and declination). The bound is invariant to the choice: the H
figures are propagated from K by the Jacobian of the inverse, `dH = -H dK H`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.calibration.turntable.observability import tangent_basis
from rig.errors import CalibrationError

N_PARAMS = 14
PARAM_NAMES = (("B_x", "B_y", "B_z") + tuple(f"K[{a},{b}]" for a in range(3) for b in range(3))
               + ("v_tilt_1", "v_tilt_2"))
# Smallest/largest eigenvalue of the correlation-scaled information below which the bound is infinite.
INFO_RCOND_MIN = 1e-12


@dataclass(frozen=True)
class CramerRao:
    """Lower bound on the covariance of unbiased estimates of (B, vec K row-major, 2 tilts of v in rad)."""

    covariance: np.ndarray      # (14, 14) over (B, K = H^-1 row-major, v tilts about `v_tangent_basis`)
    B_cov: np.ndarray           # (3, 3) counts^2
    H_cov: np.ndarray           # (9, 9) row-major vec(H), propagated from K
    B_rms: float                # sqrt(E |dB|^2) = sqrt(trace B_cov), counts
    H_rel_rms: float            # sqrt(E ||dH||_F^2) / ||H||_F
    vector_rel_rms: float       # sqrt(E |du|^2) / norm, u uniform over the sphere of radius norm
    v_tangent_basis: np.ndarray  # (3, 2) unit tilt directions of the reference
    information: np.ndarray     # (14, 14) Fisher information


def cramer_rao(R: np.ndarray, H: np.ndarray, B: np.ndarray, reference_world: np.ndarray,
               sigma: float | np.ndarray) -> CramerRao:
    """Bound for holds at fixture -> world rotations R (n, 3, 3), truth H (3, 3), B (3,), reference v
    (3,) in the world frame (its length is the norm), white noise of standard deviation sigma on each raw
    hold mean: a scalar, per hold (n,) or per hold and axis (n, 3), in counts.

    Raises CalibrationError when the holds cannot determine all 14 parameters (coplanar or conical
    reference directions, too few holds): the bound is infinite, and the message names the weakest parameters.
    vector_rel_rms: from `u_est - u = dH K u - H dB = -H dK u - H dB` averaged over directions u,
    `E|du|^2 / norm^2 = ||H dK||_F^2 / 3 + |H dB|^2 / norm^2` (what the benchmarks' vector error measures).
    """
    R, H, B, v, s = _checked(R, H, B, reference_world, sigma)
    K = np.linalg.inv(H)
    J, E = _jacobian(R, K, v)
    Jw = (J / s[:, :, None]).reshape(-1, N_PARAMS)
    F = Jw.T @ Jw
    cov = _inverse_information(F, len(R))
    A = -np.kron(H, H.T)                      # row-major vec(dH) = -vec(H dK H)
    H_cov = A @ cov[3:12, 3:12] @ A.T
    B_cov = cov[0:3, 0:3]
    HdK = np.kron(H, np.eye(3))               # row-major vec(H dK)
    norm = float(np.linalg.norm(v))
    vec_ms = np.trace(HdK @ cov[3:12, 3:12] @ HdK.T) / 3 + np.trace(H @ B_cov @ H.T) / norm**2
    return CramerRao(covariance=cov, B_cov=B_cov, H_cov=H_cov, B_rms=float(np.sqrt(np.trace(B_cov))),
                     H_rel_rms=float(np.sqrt(np.trace(H_cov)) / np.linalg.norm(H)),
                     vector_rel_rms=float(np.sqrt(vec_ms)), v_tangent_basis=E, information=F)


def _jacobian(R: np.ndarray, K: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dy_k / d(B, vec K, tilts): (n, 3, 14). A tilt alpha moves v to norm (v^ + E alpha) / |v^ + E alpha|.
    Written with matmul rather than einsum: the planner evaluates it on every sample of the planned moves."""
    n = len(R)
    Rt = np.swapaxes(R, 1, 2)
    x = Rt @ v                                                        # R_k^T v
    E = tangent_basis(v)
    J = np.zeros((n, 3, N_PARAMS))
    J[:, :, 0:3] = np.eye(3)
    for c in range(3):
        J[:, c, 3 + 3 * c:6 + 3 * c] = x
    J[:, :, 12:14] = np.linalg.norm(v) * (K @ (Rt @ E))
    return J, E


def _inverse_information(F: np.ndarray, n: int) -> np.ndarray:
    """F^-1, or CalibrationError naming the unobservable combination. Scaled to unit diagonal first so the
    test compares like with like (counts, counts per unit, radians)."""
    d = np.sqrt(np.diag(F))
    if np.any(d == 0):
        raise CalibrationError(f"cramer_rao: parameter {PARAM_NAMES[int(np.argmin(d))]} does not affect any "
                               f"reading of the {n} holds; the bound is infinite")
    C = F / np.outer(d, d)
    w, V = np.linalg.eigh(C)
    if w[0] < INFO_RCOND_MIN * w[-1]:
        weakest = np.argsort(-np.abs(V[:, 0]))[:3]
        raise CalibrationError(
            f"cramer_rao: the {n} holds do not determine B, H and the reference direction (information "
            f"matrix rank deficient, eigenvalue ratio {w[0] / w[-1]:.3g}); unobservable combination mostly "
            f"{', '.join(PARAM_NAMES[i] for i in weakest)} (coplanar or conical reference directions?); "
            "the bound is infinite")
    return np.linalg.solve(C, np.eye(N_PARAMS)) / np.outer(d, d)


def _checked(R, H, B, reference_world, sigma):
    R = np.asarray(R, dtype=float)
    H = np.asarray(H, dtype=float)
    B = np.asarray(B, dtype=float)
    v = np.asarray(reference_world, dtype=float)
    if R.ndim != 3 or R.shape[1:] != (3, 3) or len(R) == 0:
        raise CalibrationError(f"cramer_rao: R must have shape (n, 3, 3), got {R.shape}")
    if H.shape != (3, 3) or B.shape != (3,) or v.shape != (3,):
        raise CalibrationError(f"cramer_rao: H must be (3, 3), B and reference_world (3,); got {H.shape}, "
                               f"{B.shape}, {v.shape}")
    if not (np.isfinite(R).all() and np.isfinite(H).all() and np.isfinite(B).all() and np.isfinite(v).all()):
        raise CalibrationError("cramer_rao: R, H, B and reference_world must be finite")
    if not np.linalg.norm(v) > 0:
        raise CalibrationError("cramer_rao: reference_world must not be zero (its length is the norm)")
    if not abs(np.linalg.det(H)) > 0:
        raise CalibrationError("cramer_rao: H is singular")
    n = len(R)
    s = np.asarray(sigma, dtype=float)
    try:
        s = np.broadcast_to(s[:, None] if s.shape == (n,) else s, (n, 3)).astype(float)
    except ValueError:
        raise CalibrationError(f"cramer_rao: sigma must be a scalar, (n,) or (n, 3) with n = {n}; "
                               f"got shape {s.shape}") from None
    if not (np.isfinite(s).all() and (s > 0).all()):
        raise CalibrationError("cramer_rao: sigma must be finite and > 0 for every hold and axis")
    return R, H, B, v, s
