"""Joint B and H from the known hold rotations (beyond Zhang 2015).

The two-step method takes B from the ellipsoid alone, which ignores what the rotations say about B; with
few holds the ellipsoid centre is the weakest link. Here every hold is used for everything:

    y_k = H^-1 R_k^T v + B + e_k,      e_k ~ N(0, diag(sigma_k^2)),   |v| = norm,

v the reference (gravity or geomagnetic field) in the world frame, its direction unknown (table not level,
unknown dip/declination). Start: alternating linear least squares ((H^-1, B) given v; v given H^-1, B),
then the maximum-likelihood refinement by Levenberg-Marquardt with the analytic Jacobian (MINPACK's, through
scipy's `least_squares(method="lm")`), weights 1/sigma_k with
sigma_k = y_std_k / sqrt(count_k), and the parameter covariance (J^T J)^-1.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.turntable.observability import direction_problems, tangent_basis, validate_holds
from rig.calibration.numerics.quantisation import QUANTISATION_STD, mean_standard_error
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.turntable.twostep import calibrate_two_step
from rig.errors import CalibrationError

MIN_ORIENTATIONS = 6
N_PARAMS = 14  # B (3) + H (9) + direction of v (2)
MAX_CONDITION = 1e3                    # real triads, soft iron included, are within ~3
GRID_DIRECTIONS = 200                  # profile-start grid over the hemisphere: ~10 deg apart
CHI2_SUSPECT = 100.0                   # reduced chi-square above which a fit is retried from the grid start


def calibrate_joint(y_means: np.ndarray, R: np.ndarray, norm: float, *, y_std: np.ndarray | None = None,
                    counts: np.ndarray | None = None, reference_world=None, refine_ml: bool = True,
                    full_scale: float | None = None, max_alternations: int = 200,
                    tol: float = 1e-12) -> TriadCalibration:
    """Joint least-squares / maximum-likelihood B and H; see the module docstring.

    reference_world: starting guess for v's direction (e.g. (0, 0, 1) for a level accelerometer); without
    it the start is the two-step solution, or with too few distinct holds for that, the best direction of a
    grid (`profile_start`). The direction is always estimated. With y_std, a fit whose reduced chi-square
    exceeds CHI2_SUSPECT is retried from the grid start, and warned about if it stays there.
    residual_rms: RMS of |u_k - R_k^T v| (calibrated units). With y_std the covariance is scaled by the
    reduced chi-square when that exceeds 1 (unmodelled errors), else taken as is; without y_std by the
    residual variance. extra: reference_world (fitted v), reduced_chi2, v_std_deg.
    """
    y, R = validate_holds(y_means, R, min_orientations=MIN_ORIENTATIONS, full_scale=full_scale, what="joint")
    sigma = hold_sigma(y_std, counts, len(y))
    starts = _start_references(y, R, norm, reference_world, full_scale)
    result = _solve(y, R, norm, sigma, starts, refine_ml, y_std is not None, max_alternations, tol)
    chi2 = result.extra.get("reduced_chi2", 0.0)
    if y_std is not None and chi2 > CHI2_SUSPECT:
        try:
            retry = _solve(y, R, norm, sigma, [profile_start(y, R, norm)], refine_ml, True, max_alternations, tol)
        except CalibrationError:
            retry = None
        if retry is not None and retry.extra.get("reduced_chi2", np.inf) < chi2:
            result = retry
        if result.extra["reduced_chi2"] > CHI2_SUSPECT:
            result.warnings.append(f"joint: the holds misfit the model {np.sqrt(result.extra['reduced_chi2']):.3g} "
                                   "times their noise (reduced chi-square "
                                   f"{result.extra['reduced_chi2']:.3g}) from every start: a hold that moved, or "
                                   "an effect the linear model lacks")
    _fix_sign(result)
    v_fit = np.asarray(result.extra["reference_world"])
    u = result.apply(y)
    misfit = u - np.einsum("kji,j->ki", R, v_fit)
    result.residual_rms = float(np.sqrt(np.mean(np.sum(misfit**2, axis=1))))
    result.extra["norm_rms"] = float(np.sqrt(np.mean((np.linalg.norm(u, axis=1) - norm) ** 2)))
    result.extra["residual_kind"] = "rms |u_k - R_k^T v|"
    return result


def _solve(y, R, norm, sigma, starts, refine_ml: bool, weighted: bool, max_alternations: int,
           tol: float) -> TriadCalibration:
    """Alternation from each start (the best kept), observability checks, then the ML refinement."""
    fits = [_alternate(y, R, v0, norm, max_alternations, tol) for v0 in starts]
    K, B, v, alternations, converged = min(fits, key=lambda s: _sse(y, R, *s[:3]))
    _, problems, _ = direction_problems(np.einsum("kji,j->ki", R, v))
    if problems:
        raise CalibrationError(f"joint: {problems[0]}; B and H are not observable from these holds")
    if np.linalg.cond(K) > MAX_CONDITION:
        raise CalibrationError(f"joint: the fitted sensor matrix is near singular (condition {np.linalg.cond(K):.3g}); "
                               "the holds do not determine H (check the schedule with observability.check_schedule)")
    warnings = [] if converged else [f"joint: alternating least squares did not converge in {alternations} rounds"]
    result = TriadCalibration(B=B, H=np.linalg.inv(K), method="joint", iterations=alternations,
                              converged=converged, warnings=warnings)
    if refine_ml:
        return _refine_ml(y, R, norm, sigma, result, v, weighted)
    result.extra["reference_world"] = v.tolist()
    return result


def hold_sigma(y_std, counts, n: int) -> np.ndarray:
    """Standard error of each hold mean. Raw counts are integers: no sample is better than the rounding noise,
    and without noise to dither them a mean keeps a rounding bias of up to half a count however many samples
    it has (quantisation.mean_standard_error). A quiet or simulated sensor that reports std 0 is such a case."""
    if y_std is None:
        return np.ones((n, 3))
    s = np.broadcast_to(np.asarray(y_std, dtype=float), (n, 3)).copy()
    bad = np.flatnonzero(~(np.isfinite(s).all(axis=1) & (s >= 0).all(axis=1)))
    if bad.size:
        raise CalibrationError(f"joint: y_std must be finite and >= 0; holds {bad.tolist()} are not")
    if counts is None:
        return np.maximum(s, QUANTISATION_STD)
    c = np.asarray(counts, dtype=float).reshape(n)
    if np.any(~(c >= 1)):
        raise CalibrationError(f"joint: sample counts must be >= 1, holds {np.flatnonzero(~(c >= 1)).tolist()} are not")
    return mean_standard_error(s, c)


def _start_references(y, R, norm, reference_world, full_scale) -> list[np.ndarray]:
    """The given reference; else the two-step solution's; else (too few distinct holds for the ellipsoid)
    the best direction of a grid (`profile_start`)."""
    if reference_world is not None:
        v = np.asarray(reference_world, dtype=float)
        return [norm * v / np.linalg.norm(v)]
    try:
        return [np.asarray(calibrate_two_step(y, R, norm, full_scale=full_scale).extra["reference_world"])]
    except CalibrationError:
        return [profile_start(y, R, norm)]


def profile_start(y: np.ndarray, R: np.ndarray, norm: float, directions: int = GRID_DIRECTIONS) -> np.ndarray:
    """Reference v (length norm) minimising the profile SSE over a Fibonacci grid of the upper hemisphere.

    Given v the model is linear in (K, B), so each direction's best fit is one 4x4 solve per grid point, all
    in one batch. (K, v) and (-K, -v) fit alike, hence a hemisphere. Why a grid: with 6-8 holds the three
    fixture-axis starts used before all fell into a wrong minimum in 5 of 1000 random schedules (reduced
    chi-square 1e4-1e6, errors up to 1e11 times the Cramer-Rao bound); from the grid's best direction the
    same trials reach 0.95-0.98 times the bound.
    """
    k = np.arange(directions) + 0.5
    z = k / directions
    phi = k * np.pi * (3.0 - np.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    V = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    X1 = np.ones((directions, len(y), 4))
    X1[:, :, :3] = np.einsum("kji,mj->mki", R, V)                    # rows R_k^T v for every grid v
    A = np.einsum("mki,mkj->mij", X1, X1)
    A += 1e-12 * np.trace(A, axis1=1, axis2=2)[:, None, None] * np.eye(4)
    b = np.einsum("mki,kc->mic", X1, y)
    P = np.linalg.solve(A, b)
    sse = np.einsum("kc,kc->", y, y) - np.einsum("mic,mic->m", P, b)
    return norm * V[int(np.argmin(sse))]


def _sse(y, R, K, B, v) -> float:
    return float(np.sum((y - np.einsum("kji,j->ki", R, v) @ K.T - B) ** 2))


def _alternate(y, R, v, norm, max_rounds: int, tol: float):
    """(K = H^-1, B) | v and v | (K, B), both linear least squares, |v| kept at norm."""
    n = len(y)
    K = np.eye(3)
    X1 = np.ones((n, 4))
    for it in range(1, max_rounds + 1):
        X1[:, :3] = np.einsum("kji,j->ki", R, v)
        P, *_ = np.linalg.lstsq(X1, y, rcond=None)
        K_new, B = P[:3].T, P[3]
        A = np.einsum("ab,kcb->kac", K_new, R).reshape(3 * n, 3)   # rows of K R_k^T
        v, *_ = np.linalg.lstsq(A, (y - B).reshape(3 * n), rcond=None)
        v *= norm / np.linalg.norm(v)
        change = np.linalg.norm(K_new - K) / np.linalg.norm(K_new)
        K = K_new
        if change < tol:
            return K, B, v, it, True
    X1[:, :3] = np.einsum("kji,j->ki", R, v)
    P, *_ = np.linalg.lstsq(X1, y, rcond=None)
    return P[:3].T, P[3], v, max_rounds, False


def _refine_ml(y, R, norm, sigma, start: TriadCalibration, v0, weighted: bool) -> TriadCalibration:
    n = len(y)
    E = tangent_basis(v0) * norm

    def unpack(p):
        w = v0 + E @ p[12:14]
        return p[0:3], p[3:12].reshape(3, 3), norm * w / np.linalg.norm(w), w

    def residuals(p):
        B, H, v, _ = unpack(p)
        pred = np.einsum("kji,j->ki", R, v) @ np.linalg.inv(H).T + B
        return ((y - pred) / sigma).ravel()

    def jacobian(p):
        B, H, v, w = unpack(p)
        K = np.linalg.inv(H)
        s = np.einsum("kji,j->ki", R, v) @ K.T                       # K x_k
        J = np.empty((n, 3, N_PARAMS))
        J[:, :, 0:3] = -np.eye(3)
        J[:, :, 3:12] = np.einsum("ca,kb->kcab", K, s).reshape(n, 3, 9)
        wn = np.linalg.norm(w)
        dv = norm * (np.eye(3) - np.outer(w, w) / wn**2) / wn @ E     # (3, 2)
        J[:, :, 12:14] = -np.einsum("ca,kba,bd->kcd", K, R, dv)
        return (J / sigma[:, :, None]).reshape(3 * n, N_PARAMS)

    p0 = np.concatenate([start.B, start.H.ravel(), np.zeros(2)])
    sol = least_squares(residuals, p0, jac=jacobian, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14)
    B, H, v, _ = unpack(sol.x)
    dof = 3 * n - N_PARAMS
    chi2_red = float(2 * sol.cost / dof) if dof > 0 else float("nan")
    # The alternation is only the start: a slow start that the maximum-likelihood step finishes is no fault.
    out = TriadCalibration(B=B, H=H, method="joint-ml", iterations=start.iterations + int(sol.nfev),
                           converged=bool(sol.success), warnings=[] if sol.success else list(start.warnings))
    out.extra["start_converged"] = bool(start.converged)
    if not sol.success:
        out.warnings.append(f"joint-ml: least_squares did not converge ({sol.message})")
    J = sol.jac
    try:
        cov = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        out.warnings.append("joint-ml: singular information matrix, no covariance (schedule not observable)")
        cov = None
    if cov is not None and np.any(np.diag(cov) < 0):
        out.warnings.append("joint-ml: the information matrix is numerically singular, no covariance "
                            "(schedule barely observable)")
        cov = None
    if cov is not None and dof > 0:
        cov *= max(chi2_red, 1.0) if weighted else chi2_red
        out.B_cov, out.H_cov = cov[0:3, 0:3], cov[3:12, 3:12]
        out.B_std = np.sqrt(np.diag(out.B_cov))
        out.H_std = np.sqrt(np.diag(out.H_cov)).reshape(3, 3)
        out.extra["v_std_deg"] = float(np.degrees(np.sqrt(np.trace(cov[12:14, 12:14]) / 2)))
    out.extra["reference_world"] = v.tolist()
    out.extra["reduced_chi2"] = chi2_red
    return out


def _fix_sign(result: TriadCalibration) -> None:
    """(H, v) and (-H, -v) predict the same readings: keep det(H) > 0 (conventions.md)."""
    if np.linalg.det(result.H) < 0:
        result.H = -result.H
        result.extra["reference_world"] = (-np.asarray(result.extra["reference_world"])).tolist()
