"""Two-step accelerometer/magnetometer calibration with known hold rotations (Zhang et al. 2015, II.B).

Step 1 (eqs. 15-17, ellipsoid.py): B is the centre of the ellipsoid through the raw hold means.
Step 2 (eqs. 27-32 as numbered in the project brief; the paper's text could not be retrieved, so this is a
reconstruction from its abstract and the brief): with z_k = y_k - B and the known rotations
`u_k = R_k^1 u_1`, `R_k^1 = R_k^T R_1` (conventions.md), alternate
  (i)  u_1 given H: least squares over the holds, u_1 = mean_k (R_k^1)^T H z_k, scaled to |u_1| = norm;
  (ii) H given u_1: pseudo-inverse, H = [R_1^1 u_1 ... R_n^1 u_1] Z^+,
until the relative change of H is below `tol`; then rescale so mean |u_k| = norm and pick the sign with
det(H) > 0 ((H, u) and (-H, -u) fit equally well).

Why it is fast: (ii) is linear in u_1 and (i) is linear in H, so one round is `v <- M v` with a 3x3 matrix
M built once from the holds (v = R_1 u_1, the reference in the world frame). The loop runs the paper's
iteration exactly, but each round costs a 3x3 product instead of a pass over the holds. M is symmetric:
M = (1/n) sum_kl S_lk R_k R_l^T with S = Z^T (Z Z^T)^-1 Z, a projection, so its eigendecomposition gives
every power M^k v_0 of a chunk of rounds in one product.
"""

from __future__ import annotations

import numpy as np
from rig.calibration.numerics.ellipsoid import fit_ellipsoid, sphere_map
from rig.calibration.turntable.observability import ELLIPSOID_MIN_DIRECTIONS, count_distinct, validate_holds
from rig.calibration.numerics.result import TriadCalibration
from rig.errors import CalibrationError

MIN_ORIENTATIONS = 9


def calibrate_two_step(y_means: np.ndarray, R: np.ndarray, norm: float, *, max_iter: int = 100, tol: float = 1e-10,
                       record_history: bool = False, full_scale: float | None = None) -> TriadCalibration:
    """B from the ellipsoid, H by the alternating pseudo-inverse iteration; see the module docstring.

    y_means (n, 3) raw counts, R (n, 3, 3) fixture -> world, norm = G or M. residual_rms is the RMS of
    |u_k - R_k^T v| (vector misfit to the rotated reference, calibrated units); extra["norm_rms"] is the RMS
    of |u_k| - norm. extra["history"] (when asked) holds H after every iteration.
    """
    y, R = validate_holds(y_means, R, min_orientations=MIN_ORIENTATIONS, full_scale=full_scale, what="two-step")
    fit = fit_ellipsoid(y, what="two-step", check_repeats=False)
    n = len(y)
    Z = (y - fit.center).T
    Zpinv = np.linalg.solve(Z @ Z.T, Z).T                                   # (n, 3) pseudo-inverse of the full-rank Z
    G = (R.reshape(n, 9).T @ Zpinv).reshape(3, 9)                 # step (ii): vec H = v @ G
    M = np.einsum("kab,jbk->aj", R, (G.reshape(9, 3) @ Z).reshape(3, 3, n)) / n   # (ii)+(i): v <- M v
    R_wide = R.transpose(1, 0, 2).reshape(3, 3 * n)               # sum_k R_k w_k = R_wide @ w.ravel()
    h = sphere_map(fit, norm).ravel()
    v = R_wide @ (Z.T @ h.reshape(3, 3).T).ravel() / n
    if not np.dot(v, v) > (1e-12 * norm) ** 2:
        v = np.array([0.0, 0.0, norm])
    h, v, it, converged, history = _iterate(v, M, G, h, norm, max_iter, tol, record_history)
    return _finish(h.reshape(3, 3), fit.center, R, R_wide, Z.T, norm, it, converged, history, fit.residual)


CHUNK = 16
_ROUNDS = np.arange(CHUNK)[:, None]   # the power of M of each row of a chunk


def _iterate(v: np.ndarray, M: np.ndarray, G: np.ndarray, h: np.ndarray, norm: float, max_iter: int, tol: float,
             record_history: bool):
    """The paper's rounds `h_k = (norm v/|v|) G`, `v <- M v`, until |h_k - h_(k-1)| < tol |h_k|.

    The direction of v after k rounds is that of M^k v_0, so the rounds are taken CHUNK at a time: the
    powers M^k v_0 from the eigendecomposition of the symmetric M, then the normalisation, h and the
    convergence test for the whole chunk at once. Same iterates to rounding, same stopping round.
    """
    history = [] if record_history else None
    it, tol2 = 0, tol * tol
    w, Q = np.linalg.eigh(M)
    while it < max_iter:
        m = min(CHUNK, max_iter - it)
        V = ((w ** _ROUNDS) * (v @ Q)) @ Q.T     # rows M^j v, j = 0 .. CHUNK - 1
        V = V[:m]
        V *= norm / np.sqrt(np.einsum("ij,ij->i", V, V))[:, None]
        Hs = np.empty((m + 1, 9))
        Hs[0] = h
        np.matmul(V, G, out=Hs[1:])
        d = Hs[1:] - Hs[:-1]
        done = np.flatnonzero(np.einsum("ij,ij->i", d, d) < tol2 * np.einsum("ij,ij->i", Hs[1:], Hs[1:]))
        k = int(done[0]) + 1 if done.size else m
        if history is not None:
            history.extend(Hs[1:k + 1].reshape(-1, 3, 3))
        h, v, it = Hs[k], V[k - 1], it + k
        if done.size:
            return h, v, it, True, history
        v = M @ v
    return h, v, it, False, history


def _refuse_repeated_directions(x: np.ndarray) -> None:
    """Holds that differ only by a turn about the reference give the same reading: the ellipsoid then rests on
    fewer than 9 points and its centre is wrong however small the noise looks. Refuse, naming the count.
    x: the unit reference directions R_k^T v / |v| of the holds."""
    distinct = count_distinct(x, unit=True)
    if distinct < ELLIPSOID_MIN_DIRECTIONS:
        raise CalibrationError(f"two-step: only {distinct} distinct reference directions among {len(x)} holds "
                               f"(the ellipsoid needs {ELLIPSOID_MIN_DIRECTIONS}); add orientations or use the "
                               "joint method")


def normalise_history(Hs: np.ndarray, z: np.ndarray, norm: float) -> np.ndarray:
    """Each iterate as a standalone estimate: rescaled to mean |u_k| = norm, sign with det > 0."""
    u_norm = np.linalg.norm(np.einsum("tij,kj->tki", Hs, z), axis=2).mean(axis=1)
    sign = np.sign(np.linalg.det(Hs))
    return Hs * (sign * norm / u_norm)[:, None, None]


def _finish(H: np.ndarray, B: np.ndarray, R: np.ndarray, R_wide: np.ndarray, z: np.ndarray, norm: float,
            iterations: int, converged: bool, history: list | None, ellipsoid_residual: float) -> TriadCalibration:
    """Rescale so mean |u_k| = norm, sign with det(H) > 0, refuse repeated reference directions, and the
    residuals of the result."""
    u = z @ H.T
    u_norm = np.sqrt(np.einsum("ij,ij->i", u, u))
    scale = norm / u_norm.mean()
    if _det3(H) < 0:
        scale = -scale
    H = H * scale
    u *= scale
    n = len(z)
    v = R_wide @ u.ravel() / n
    v *= norm / np.sqrt(v @ v)
    x = v @ R                                                        # rows R_k^T v
    _refuse_repeated_directions(x / norm)
    misfit = u - x
    norm_err = u_norm * abs(scale) - norm
    warnings = [] if converged else [f"two-step: H did not converge in {iterations} iterations"]
    extra = {"reference_world": v.tolist(), "norm_rms": float(np.sqrt(norm_err @ norm_err / n)),
             "ellipsoid_residual": ellipsoid_residual, "residual_kind": "rms |u_k - R_k^T v|"}
    if history is not None:
        extra["history"] = list(normalise_history(np.array(history), z, norm))
    return TriadCalibration(B=B, H=H, method="two-step", residual_rms=float(np.sqrt(np.vdot(misfit, misfit) / n)),
                            iterations=iterations, converged=converged, warnings=warnings, extra=extra)


def _det3(A: np.ndarray) -> float:
    """3x3 determinant in plain floats: a fifth of np.linalg.det's cost on one small matrix."""
    a, b, c, d, e, f, g, h, i = A.ravel().tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
