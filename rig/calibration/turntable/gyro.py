"""Gyroscope calibration against known rig rotations (Zhang et al., IEEE TIE 62(6) 2015, section II.C).

Model: `omega = H (y - B)` (conventions.md). B is the mean of the stationary holds (eq. 41); H is the
3x3 matrix for which the rate integrated over every move reproduces the rotation the table made,
`Int(H (y - B)) = R_j^T R_{j+1}` (eqs. 52-55 for Int). The paper estimates H with an unscented
Kalman filter whose state is the nine entries of H with a random-walk process (eqs. 44-45).

Equation numbers follow the brief; the paper's text could not be retrieved here, so the
measurement is our reconstruction: per move, the rotation vector of `R_known^T R_int(H)`, whose
expected value is zero. Using the rotation error (not Euler angles or a quaternion difference)
keeps the measurement 3-dimensional, smooth at the solution and free of sign ambiguity.

The filter's sigma points and measurement transform are filterpy's (MerweScaledSigmaPoints,
unscented_transform); its update is written out because filterpy's UnscentedKalmanFilter calls h once per
sigma point, and here h integrates a whole move, for all sigma points in one vectorised call (the gyro tests
hold the fit equal to one run through filterpy's filter). The scale search refines by scipy's bounded Brent.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from rig.calibration.turntable.gyro_start import start_candidates
from rig.calibration.numerics.integrate import SAMPLE_MODELS, cross, interval_terms, product_of_exps
from rig.calibration.numerics.result import TriadCalibration
from rig.quaternions import cube_rotations, quat_from_matrix, rotvec_from_quat
from rig.session_data import MoveStream


# Rotation misfit per move (rms, rad) above which a result is flagged: MEMS noise gives ~1e-3..1e-2.
POOR_FIT_RAD = 0.05


def gyro_bias(hold_means: np.ndarray, counts: np.ndarray | None = None) -> np.ndarray:
    """Eq. 41: the gyro bias is the mean raw output while the table is still (earth rate ignored).

    Holds are weighted by their sample counts so long holds count for what they measured.
    """
    means = np.asarray(hold_means, dtype=float).reshape(-1, 3)
    if means.shape[0] == 0:
        raise ValueError("gyro_bias: no stationary holds given")
    w = np.ones(len(means)) if counts is None else np.asarray(counts, dtype=float).ravel()
    if w.shape != (len(means),) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"gyro_bias: counts must be {len(means)} non-negative numbers with a positive sum, got {w!r}")
    return (w[:, None] * means).sum(axis=0) / w.sum()


@dataclass
class MoveSet:
    """The moves' raw data reduced to what the Magnus step needs, padded to one length.

    Each interval's rotation vector is a linear part plus a cross product of two linear combinations of
    the samples (integrate.interval_terms); for `w = H u` it is `S H^T + C cof(H)^T` with S and C fixed by
    the raw data, because `(H a) x (H b) = cof(H) (a x b)`. Padding intervals have S = C = 0 (identity).
    """

    S: np.ndarray          # (n, L, 3) counts * s
    C: np.ndarray          # (n, L, 3) counts^2 * s^2
    h: np.ndarray          # (n, L) interval lengths, s (0 for padding)
    q_known: np.ndarray    # (n, 4) R_j^T R_{j+1}
    steps: list[int]
    samples: str = "point"   # what a raw sample means (integrate.SAMPLE_MODELS)
    _buckets: list | None = field(default=None, init=False, repr=False)

    @classmethod
    def build(cls, moves: list[MoveStream], B: np.ndarray, samples: str = "point") -> "MoveSet":
        if not moves:
            raise ValueError("gyro calibration: no moves given")
        B = np.asarray(B, dtype=float).reshape(3)
        lengths = []
        for mv in moves:
            if len(mv.t) < 2 or mv.y.shape != (len(mv.t), 3):
                raise ValueError(f"move after hold {mv.step}: need >= 2 samples of 3 axes, "
                                 f"got t {np.shape(mv.t)}, y {np.shape(mv.y)}")
            if not np.all(np.isfinite(mv.y)):
                raise ValueError(f"move after hold {mv.step}: raw gyro samples contain NaN/inf")
            if np.any(np.diff(mv.t) <= 0):
                raise ValueError(f"move after hold {mv.step}: time stamps do not increase")
            lengths.append(len(mv.t) - 1)
        n, L = len(moves), max(lengths)
        t = np.concatenate([np.asarray(mv.t, dtype=float) for mv in moves])
        u = np.concatenate([np.asarray(mv.y, dtype=float) for mv in moves]) - B
        counts = np.array(lengths)
        rows = np.repeat(np.arange(n), counts), np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        S, C, hs = np.zeros((n, L, 3)), np.zeros((n, L, 3)), np.zeros((n, L))
        S[rows], C[rows] = interval_terms(t, u, samples, counts + 1)
        hs[rows] = np.concatenate([np.diff(np.asarray(mv.t, dtype=float)) for mv in moves])
        q_known = quat_from_matrix(np.array([mv.known_rotation for mv in moves]))
        return cls(S, C, hs, np.atleast_2d(q_known), [int(mv.step) for mv in moves], samples)

    def buckets(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """(move indices, S, C) trimmed to the longest move of each power-of-two length class.

        Moves of very different lengths (a long rest inside one of them) would otherwise all be
        padded to the longest; bucketing keeps the padding below 2x.
        """
        if self._buckets is None:
            lengths = np.count_nonzero(self.h > 0, axis=1)
            cls = np.ceil(np.log2(np.maximum(lengths, 1))).astype(int)
            self._buckets = []
            for c in np.unique(cls):
                idx = np.flatnonzero(cls == c)
                L = int(lengths[idx].max())
                self._buckets.append((idx, self.S[idx, :L], self.C[idx, :L]))
        return self._buckets

    def subset(self, i: int) -> "MoveSet":
        """Move i alone, without padding."""
        L = int(np.count_nonzero(self.h[i] > 0))
        return MoveSet(self.S[i:i + 1, :L], self.C[i:i + 1, :L], self.h[i:i + 1, :L], self.q_known[i:i + 1],
                       self.steps[i:i + 1], self.samples)


def cofactor(H: np.ndarray) -> np.ndarray:
    """cof(H) = det(H) H^-T for a stack (..., 3, 3), from row cross products."""
    r0, r1, r2 = H[..., 0, :], H[..., 1, :], H[..., 2, :]
    return np.stack([cross(r1, r2), cross(r2, r0), cross(r0, r1)], axis=-2)


def integrated_quats(H: np.ndarray, ms: MoveSet) -> np.ndarray:
    """Int(H (y - B)) for every move, as quaternions (..., n, 4), for a stack of H (..., 3, 3)."""
    H = np.asarray(H, dtype=float)
    Ht = np.swapaxes(H, -1, -2)[..., None, :, :]
    Ct = np.swapaxes(cofactor(H), -1, -2)[..., None, :, :]
    buckets = ms.buckets()
    if len(buckets) == 1:
        return product_of_exps(ms.S @ Ht + ms.C @ Ct)
    out = np.empty(H.shape[:-2] + (len(ms.steps), 4))
    for idx, S, C in buckets:
        out[..., idx, :] = product_of_exps(S @ Ht + C @ Ct)
    return out


def rotation_residuals(H: np.ndarray, ms: MoveSet) -> np.ndarray:
    """Rotation vectors of R_known^T R_int(H) per move (..., n, 3), angle in [0, pi] (eq. 43 terms)."""
    q = integrated_quats(H, ms)
    k = ms.q_known * np.array([1.0, -1.0, -1.0, -1.0])
    w = k[..., 0] * q[..., 0] - np.einsum("...i,...i->...", k[..., 1:], q[..., 1:])
    v = k[..., :1] * q[..., 1:] + q[..., :1] * k[..., 1:] + cross(k[..., 1:], q[..., 1:])
    sign = np.where(w < 0, -1.0, 1.0)
    w, v = w * sign, v * sign[..., None]
    sn = np.linalg.norm(v, axis=-1)
    angle = 2.0 * np.arctan2(sn, w)
    scale = np.where(sn > 1e-12, angle / np.where(sn > 1e-12, sn, 1.0), 2.0 / np.maximum(w, 1e-300))
    return v * scale[..., None]


def nominal_scale(moves: list[MoveStream], B: np.ndarray, *, mounting: np.ndarray | None = None,
                  min_rate_dps: float = 1.0, max_rate_dps: float = 3000.0, stride: int = 4) -> float:
    """A scalar s so that H0 = s Q (Q = `mounting`, default I) integrates closest to the known rotations.

    Used when no nominal H0 is given. (A per-axis least squares of integrated angles is not enough on its
    own: the rotation vector of a move wraps at pi and two-axis moves do not turn about a fixed axis.)

    The cost over s has one basin per winding of each move, so a log grid (5 % steps, coarse
    enough to be cheap, fine enough for basins about +-50 % wide) covering peak body rates of
    `min_rate_dps`..`max_rate_dps` is searched first and the best cell refined; every `stride`-th
    sample is enough for a start point.
    """
    return scale_search(MoveSet.build(decimated(moves, stride), B), mounting, min_rate_dps, max_rate_dps)


def scale_search(ms: MoveSet, mounting: np.ndarray | None = None, min_rate_dps: float = 1.0,
                 max_rate_dps: float = 3000.0) -> float:
    """nominal_scale on moves already reduced to a MoveSet."""
    Q = np.eye(3) if mounting is None else np.asarray(mounting, dtype=float)
    mean_rates = np.linalg.norm(ms.S, axis=-1) / np.where(ms.h > 0, ms.h, np.inf)
    peak = float(mean_rates.max())
    if not np.isfinite(peak) or peak <= 0:
        raise ValueError("gyro calibration: the moves show no rotation (raw rates equal the bias)")
    lo, hi = np.radians(min_rate_dps) / peak, np.radians(max_rate_dps) / peak
    cost = lambda s: _scalar_cost(s, ms, Q)  # noqa: E731
    # A move's net angle cannot exceed s times its raw path length, so s >= angle / path for every move;
    # the largest of these bounds is close to s when moves turn about nearly fixed axes: search near it
    # first, and over the whole range only if the best lies at the edge of that bracket.
    bound = path_bound(ms)
    if np.isfinite(bound) and lo < bound < hi:
        a, b = bound * 0.8, min(bound * 2.5, hi)      # anisotropic scales let angle/path exceed s a little
        s = scalar_search(cost, a, b)
        if a * 1.06 < s < b / 1.06:
            return s
    return scalar_search(cost, lo, hi)


def path_bound(ms: MoveSet) -> float:
    """max over moves of (net angle / raw path length): a lower bound of the scale, independent of mounting."""
    path = np.linalg.norm(ms.S, axis=-1).sum(axis=1)
    angle = np.linalg.norm(rotvec_from_quat(ms.q_known), axis=-1)
    return float(np.max(angle / np.where(path > 0, path, np.inf)))


CUBE_ROTATIONS = cube_rotations()   # the 24 ways to mount a board square to the fixture


def square_mounting(ms: MoveSet) -> np.ndarray:
    """The cube rotation (sensor axes along +-fixture axes) that fits the moves best at the path-bound scale.

    Any mounting is within ~63 deg of one of them, inside the fits' basin (~60 deg) or close to it; the
    linear starts of gyro_start.py cover the rest."""
    s = path_bound(ms)
    if not np.isfinite(s) or s <= 0:
        return np.eye(3)
    r = rotation_residuals(s * CUBE_ROTATIONS, ms)
    return CUBE_ROTATIONS[int(np.argmin(np.sum(r * r, axis=(-1, -2))))]


def initial_H(moves: list[MoveStream], B: np.ndarray, stride: int = 4) -> np.ndarray:
    """The fits' start: `s Q` with Q the best square mounting, or a linear start that carries any mounting
    (gyro_start.py), whichever integrates closest to the known rotations over all moves."""
    ms = MoveSet.build(decimated(moves, stride), B)
    Q = square_mounting(ms)
    candidates = [scale_search(ms, Q) * Q] + start_candidates(moves, B)
    r = rotation_residuals(np.array(candidates), ms)
    return candidates[int(np.argmin(np.sum(r * r, axis=(-1, -2))))]


def start_and_scale(moves: list[MoveStream], B: np.ndarray, H0: np.ndarray | None, who: str) -> tuple[np.ndarray, float]:
    """The fits' start H (initial_H unless given) and s = |det H|^(1/3), by which they work on O(1) numbers."""
    H = np.asarray(initial_H(moves, B) if H0 is None else H0, dtype=float).reshape(3, 3)
    s = abs(np.linalg.det(H)) ** (1.0 / 3.0)
    if not s > 0:
        raise ValueError(f"{who}: H0 is singular: {H.tolist()}")
    return H, s


def decimated(moves: list[MoveStream], stride: int) -> list[MoveStream]:
    """Every `stride`-th sample of each move, keeping its last one (for cheap coarse searches)."""
    return [MoveStream(m.step, np.r_[m.t[:-1:stride], m.t[-1]], np.vstack([m.y[:-1:stride], m.y[-1:]]),
                       m.R_start, m.R_end) for m in moves]


def scalar_search(cost_batch, lo: float, hi: float, step: float = 1.05) -> float:
    """Minimise cost_batch(s) (vectorised over s) on a log grid, then refine in the best cell."""
    grid = np.exp(np.arange(np.log(lo), np.log(hi) + np.log(step), np.log(step)))
    costs = np.concatenate([cost_batch(chunk) for chunk in np.array_split(grid, max(1, len(grid) // 16))])
    i = int(np.argmin(costs))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    best = minimize_scalar(lambda s: float(cost_batch(np.array([s]))[0]), bounds=(a, b), method="bounded",
                           options={"xatol": 1e-6 * grid[i]})
    return float(best.x) if best.fun <= costs[i] else float(grid[i])


def _scalar_cost(s: np.ndarray, ms: MoveSet, Q: np.ndarray) -> np.ndarray:
    H = np.asarray(s, dtype=float)[:, None, None] * Q
    r = rotation_residuals(H, ms)
    return np.sum(r * r, axis=(-1, -2))


def _moves_rms(H: np.ndarray, ms: MoveSet) -> tuple[float, np.ndarray]:
    r = rotation_residuals(H, ms)
    per_move = np.linalg.norm(r, axis=-1)
    return float(np.sqrt(np.mean(per_move ** 2))), per_move


def calibrate_gyro_ukf(moves: list[MoveStream], B: np.ndarray, *, H0: np.ndarray | None = None,
                       noise_rad: float = 1e-3, max_passes: int = 20, min_passes: int = 3, tol: float = 1e-4,
                       prior_rel_std: float = 0.1, process_rel_std: float = 0.0, sigma_alpha: float = 0.1,
                       first_pass_stride: int = 4, history: list | None = None,
                       weight_by_duration: bool = True, samples: str = "point") -> TriadCalibration:
    """Gyro H by the UKF of eqs. 44-45 over the moves, repeated in passes until H stops changing.

    State: vec(H) (row-major) divided by s = |det H0|^(1/3), so the filter works on numbers of order 1.
    Process: random walk x_k = x_{k-1} + w, w ~ N(0, process_rel_std^2 I) (0 for a constant sensor).
    Measurement per move: z = rotvec(R_known^T Int(H (y - B))) = 0 + v, v ~ N(0, noise_rad^2 I); the
    default 1e-3 rad is the angle random walk of a 0.005 rad/s-noise MEMS gyro over a ~5 s move.
    All sigma points of one move are integrated in one vectorised call.

    Passes: each restarts from the previous pass's H with a fresh prior covariance, so the final
    covariance is that of one pass over the data, not over-confident from reusing it. The first pass
    (prior `prior_rel_std` of s per entry) only has to reach the basin, so it integrates every
    `first_pass_stride`-th sample. Later priors shrink to max(3 x last change, 10 x posterior spread):
    the unscented mean carries a curvature term proportional to the prior covariance, which with the
    wide first prior biases H by ~1e-5 (clean) to ~0.3 sigma (noisy) against least squares; the
    narrow prior removes it while still weighing < 1 % against the data. The covariance is rescaled
    by the a-posteriori variance factor (residual sum of squares / (3 n - 9)) / noise_rad^2 so H_std
    reflects the noise actually seen. Stops after >= `min_passes` passes when a pass changes H by
    less than `tol` (relative Frobenius norm). `samples`: what a raw sample means (integrate.interval_terms).
    """
    ms = MoveSet.build(moves, B, samples)
    H, s = start_and_scale(moves, B, H0, "calibrate_gyro_ukf")
    if not noise_rad > 0:
        raise ValueError(f"calibrate_gyro_ukf: noise_rad must be positive, got {noise_rad!r}")
    if max_passes < 1:
        raise ValueError(f"calibrate_gyro_ukf: max_passes must be >= 1, got {max_passes}")
    from filterpy.kalman import MerweScaledSigmaPoints   # with scipy.stats, a second of import only this fit uses

    points = MerweScaledSigmaPoints(9, alpha=sigma_alpha, beta=2.0, kappa=0.0)
    Q = np.eye(9) * process_rel_std ** 2
    full = _singles(ms)
    coarse = full if first_pass_stride <= 1 else _singles(MoveSet.build(decimated(moves, first_pass_stride), B, samples))
    w = move_weights(ms) if weight_by_duration else np.ones(len(ms.steps))
    passes, converged, prior = 0, False, prior_rel_std
    for passes in range(1, max_passes + 1):
        x, P = H.ravel() / s, np.eye(9) * prior ** 2
        for one, wi in zip(coarse if passes == 1 else full, w):
            x, P = _ukf_move_update(x, P, Q, one, s, noise_rad ** 2 * wi, points)
        H_new = x.reshape(3, 3) * s
        change = float(np.linalg.norm(H_new - H) / np.linalg.norm(H_new))
        spread = float(np.sqrt(np.max(np.diag(P)) * _variance_factor(H_new, ms, noise_rad, w)))
        prior = min(prior_rel_std, max(3.0 * change, 10.0 * spread, 1e-6))
        H = H_new
        if history is not None:
            history.append(H.copy())
        if change < tol and passes >= min_passes:
            converged = True
            break
    variance_factor = _variance_factor(H, ms, noise_rad, w)
    return gyro_result(H, B, ms, P * s * s * variance_factor, "gyro-ukf", passes, converged,
                       {"noise_rad": float(noise_rad), "variance_factor": variance_factor, "moves": len(ms.steps),
                        "last_change": change, "sample_model": samples})


def calibrate_gyro(moves: list[MoveStream], B: np.ndarray, *, samples: str = "auto", H0: np.ndarray | None = None,
                   rate_noise_counts: np.ndarray | None = None) -> TriadCalibration:
    """The UKF fit (calibrate_gyro_ukf) with the sample model the data support.

    A session does not say whether a gyro sample is the rate at its time stamp or its mean over the sample
    period, and reading one as the other leaves a systematic H error (0.03 % for 200 deg/s moves at 50 Hz)
    that no amount of data removes. With samples="auto" the point reading is fitted first; given the gyro's
    per-sample noise (`rate_noise_counts`, per axis), a misfit the noise explains (mean square at most
    AUTO_MISFIT_RATIO times the angle random walk of the moves) ends it there, since the other reading cannot
    then be told apart. Otherwise the mean reading is fitted too and the one whose integrated moves match the
    known rotations better is kept: the two fits have the same parameters, so the misfit compares them fairly.
    """
    if samples != "auto":
        return calibrate_gyro_ukf(moves, B, H0=H0, samples=samples)
    first = calibrate_gyro_ukf(moves, B, H0=H0, samples=SAMPLE_MODELS[0])
    ratio = None if rate_noise_counts is None else misfit_to_noise(first, moves, rate_noise_counts)
    fits = [first]
    if ratio is None or ratio > AUTO_MISFIT_RATIO:
        for model in SAMPLE_MODELS[1:]:         # the readings differ by ~1e-4 in H: start from the first fit
            fits.append(calibrate_gyro_ukf(moves, B, H0=first.H, samples=model))
    best = min(fits, key=lambda c: c.residual_rms)
    best.extra["misfit_rad_by_sample_model"] = {m: c.residual_rms for m, c in zip(SAMPLE_MODELS, fits)}
    if ratio is not None:
        best.extra["point_misfit_to_noise"] = ratio
    return best


AUTO_MISFIT_RATIO = 1.5   # noise-limited sessions measured 0.8-1.1; a wrong reading at 50 Hz, 5-40


def misfit_to_noise(cal: TriadCalibration, moves: list[MoveStream], rate_noise_counts: np.ndarray) -> float:
    """Mean square rotation misfit of the moves over what white rate noise alone gives: the angle random walk
    `tr(H S H^T) sum_k h_k^2` of each move, S = diag(rate_noise_counts^2)."""
    per_move = np.asarray(cal.extra["residual_rad_per_move"], dtype=float)
    noise = np.asarray(rate_noise_counts, dtype=float).reshape(3)
    walk = np.trace(cal.H @ np.diag(noise ** 2) @ cal.H.T) * np.array([np.sum(np.diff(m.t) ** 2) for m in moves])
    return float(np.mean(per_move ** 2) / np.mean(walk))


def _singles(ms: MoveSet) -> list[MoveSet]:
    return [ms.subset(i) for i in range(len(ms.steps))]


def move_weights(ms: MoveSet) -> np.ndarray:
    """Relative misfit variance of each move: white rate noise integrates to an angle random walk whose
    variance grows with the move's duration, so a long move's rotation is trusted less (weighted least
    squares; equal weights over-count the noisiest moves when move lengths differ)."""
    T = ms.h.sum(axis=1)
    return T / T.mean()


def _variance_factor(H: np.ndarray, ms: MoveSet, noise_rad: float, w: np.ndarray | None = None) -> float:
    r = rotation_residuals(H, ms)
    r = (r / np.sqrt(w)[:, None] if w is not None else r).ravel()
    return float(r @ r) / max(r.size - 9, 1) / noise_rad ** 2


def _ukf_move_update(x: np.ndarray, P: np.ndarray, Q: np.ndarray, one: MoveSet, s: float, r_var: float,
                     points) -> tuple[np.ndarray, np.ndarray]:
    """Predict, then update (x, P) with one move; h(x) of all sigma points comes from one batched integration.

    The prediction is the identity process: the unscented transform would return x and P unchanged, so
    only the process noise is added before the sigma points are drawn. The update is the UKF's (Wan & van der
    Merwe, "The unscented Kalman filter for nonlinear estimation", 2000; filterpy's UnscentedKalmanFilter.update
    computes the same): the measurement's mean zp and covariance S by the unscented transform, the cross
    covariance Pxz = sum Wc_i (X_i - x)(Z_i - zp)^T, the gain K = Pxz S^-1, then x - K zp (the measurement is
    z = 0) and P - K S K^T.
    """
    from filterpy.kalman import unscented_transform

    P = P + Q
    sigmas = points.sigma_points(x, P)
    z_sigma = rotation_residuals(sigmas.reshape(-1, 3, 3) * s, one)[:, 0, :]
    zp, S = unscented_transform(z_sigma, points.Wm, points.Wc, np.eye(3) * r_var)
    Pxz = (points.Wc[:, None] * (sigmas - x)).T @ (z_sigma - zp)
    K = Pxz @ np.linalg.inv(S)
    x, P = x - K @ zp, P - K @ S @ K.T
    return x, 0.5 * (P + P.T)


def gyro_result(H: np.ndarray, B: np.ndarray, ms: MoveSet, H_cov: np.ndarray, method: str, iterations: int,
                converged: bool, extra: dict) -> TriadCalibration:
    """The TriadCalibration of a gyro fit, with the per-move misfit and the sanity warnings."""
    rms, per_move = _moves_rms(H, ms)
    warnings = []
    if rms > POOR_FIT_RAD:
        worst = int(np.argmax(per_move))
        warnings.append(f"the fit does not explain the moves: rms rotation misfit {rms:.3g} rad (worst: move after "
                        f"hold {ms.steps[worst]}, {per_move[worst]:.3g} rad); check the known rotations, the bias "
                        f"and the axis signs (a mirrored axis cannot be fitted with det(H) > 0)")
    if np.linalg.det(H) <= 0:
        warnings.append(f"det(H) = {np.linalg.det(H):.3g} <= 0: a mirrored gyro axis or a failed fit")
    if not converged:
        warnings.append(f"{method}: not converged after {iterations} iterations")
    H_cov = 0.5 * (H_cov + H_cov.T)
    extra = dict(extra, residual_rad_per_move=per_move.tolist())
    return TriadCalibration(B=np.asarray(B, dtype=float).reshape(3).copy(), H=H, method=method, residual_rms=rms,
                            iterations=iterations, converged=converged,
                            H_std=np.sqrt(np.clip(np.diag(H_cov), 0, None)).reshape(3, 3), H_cov=H_cov,
                            warnings=warnings, extra=extra)
