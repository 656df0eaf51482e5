"""Calibration without known rotations (hand-held multi-position data such as imu_tk's Xsens set).

Follows imu_tk (Tedaldi et al., ICRA 2014), with our model `u = H (y - B)`:
* Accelerometer: static intervals detected from the data for k = 2..10 (imu_tk's sweep), each cut where the gyro
  shows the unit turning (`gyro_still`: a turn about the vertical leaves the accelerometer still); for
  each k the first 100 samples of every interval longer than that are fitted to `|H (y - B)| = g` with H upper
  triangular (imu_tk's convention: the accelerometer frame *is* the body frame, no rotation is
  observable without known orientations); start from the algebraic ellipsoid (`fit_ellipsoid`),
  whose shape matrix A = U^T U gives the upper-triangular start H = g U directly. The k with the
  lowest final cost (1/2 sum r^2, as imu_tk) wins.
* Gyroscope: B = mean of the initial static interval (eq. 41 on one hold); H (full 3x3, mapping
  into the accelerometer frame) makes the calibrated gyro, integrated from the end of one static
  interval to the start of the next, carry the gravity direction (calibrated accelerometer mean
  over the whole interval) of one onto the next: residual R^T g0 - g1 on unit vectors, as imu_tk's
  MultiPosGyroResidual. No rotation about gravity is seen by one move, but the different poses
  make all of H observable.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.ellipsoid import fit_ellipsoid
from rig.calibration.levenberg import minimise
from rig.calibration.gyro import MoveSet, decimated, integrated_quats, scalar_search
from rig.calibration.gyro_still import split_turning, turning_threshold
from rig.calibration.result import TriadCalibration
from rig.calibration.sampling import refuse_coarse_motions
from rig.calibration.saturation import pinned_rows, rail_names
from rig.calibration.static_detect import (
    detect_static_intervals,
    first_samples,
    initial_interval,
    long_intervals,
    moving_variance_norm,
    window_samples,
)
from rig.errors import CalibrationError
from rig.session_data import MoveStream

MIN_INTERVALS = 10          # the accelerometer's 9 unknowns and one pose to spare, so that its fit has a residual
IMU_TK_INTERVALS = 12       # imu_tk's own minimum: fewer is fitted, with a warning
INITIAL_REST_S = 50.0       # imu_tk's initial static interval, unless the recording says its own (initial_rest_s)
SAMPLES_PER_INTERVAL = 100  # imu_tk's interval_n_samples
UPPER = np.triu_indices(3)
POOR_FIT_UNIT = 0.05        # rms gravity-direction misfit (unit vector components); imu_tk's Xsens fit: 0.012
GAP_FACTOR = 5.0            # a motion whose samples have a gap longer than this many sample periods is not whole


def calibrate_turntable_free(t: np.ndarray, accel_raw: np.ndarray, gyro_raw: np.ndarray, *, gravity: float = 9.80665,
                             init_static_s: float = INITIAL_REST_S, k_values: range | tuple = range(2, 11),
                             window_s: float = 1.0, columns: dict[str, list[str]] | None = None
                             ) -> dict[str, TriadCalibration]:
    """{'accel': ..., 'gyro': ...} from raw counts of a hand-held multi-position record.

    The record must start with `init_static_s` seconds at rest (threshold and gyro bias) and hold
    at least 12 poses for >= 100 samples each. The accelerometer's `extra` holds the chosen k, the
    static intervals kept ("intervals"), the samples fitted ("fit_samples": the first 100 of each, as
    imu_tk) and the whole k sweep; `residual_rms` is | |a| - g | over the fitted samples and
    `extra["residual_rms_full_intervals"]` over every sample of the intervals. Poses and motions with a sample
    at a rail (saturated) are left out, named with the user's `columns` ({'accel': ['ax', 'ay', 'az'], ...}).
    """
    t = np.asarray(t, dtype=float)
    accel_raw, gyro_raw = np.asarray(accel_raw, dtype=float), np.asarray(gyro_raw, dtype=float)
    for name, a in (("accel", accel_raw), ("gyro", gyro_raw)):
        if a.shape != (len(t), 3):
            raise ValueError(f"turntable-free: {name} must have shape ({len(t)}, 3), got {a.shape}")
        if not np.all(np.isfinite(a)):
            row = int(np.flatnonzero(~np.isfinite(a).all(axis=1))[0])
            raise ValueError(f"turntable-free: {name} contains NaN/inf at row {row}")
    columns = columns or {}
    accel = _accel_sweep(t, accel_raw, gyro_raw, gravity, init_static_s, k_values, window_s, columns.get("accel"))
    intervals = [tuple(c) for c in accel.extra["intervals"]]
    g_body = accel.apply(np.array([accel_raw[a:b + 1].mean(axis=0) for a, b in intervals]))
    gyro = calibrate_gyro_gravity(t, gyro_raw, g_body, intervals, init_static_s, columns.get("gyro"))
    return {"accel": accel, "gyro": gyro}


def _accel_sweep(t: np.ndarray, accel_raw: np.ndarray, gyro_raw: np.ndarray, gravity: float, init_static_s: float,
                 k_values, window_s: float, columns: list[str] | None = None) -> TriadCalibration:
    """imu_tk's threshold sweep: detect (and cut where the gyro turns), fit, keep the k with the least cost."""
    best, sweep = None, []
    turning = turning_threshold(t, gyro_raw, window_s=window_s, init_static_s=init_static_s)
    found, pinned = pinned_rows(accel_raw)
    saturated = 0
    for k in k_values:
        intervals = detect_static_intervals(t, accel_raw, window_s=window_s, init_static_s=init_static_s, k=k)
        intervals = split_turning(t, gyro_raw, intervals, turning, window_s=window_s)
        intervals, spoiled = unpinned(intervals, pinned)
        chunks = first_samples(intervals, SAMPLES_PER_INTERVAL)
        saturated = max(saturated, len(long_intervals(spoiled, SAMPLES_PER_INTERVAL)))
        if len(chunks) < MIN_INTERVALS:
            sweep.append({"k": k, "intervals": len(chunks), "cost": None})
            continue
        B, H, cost = fit_accel_upper([accel_raw[a:b + 1] for a, b in chunks], gravity)
        sweep.append({"k": k, "intervals": len(chunks), "cost": cost})
        if best is None or cost < best["cost"]:
            best = {"k": k, "chunks": chunks, "intervals": long_intervals(intervals, SAMPLES_PER_INTERVAL),
                    "B": B, "H": H, "cost": cost, "saturated": len(long_intervals(spoiled, SAMPLES_PER_INTERVAL))}
    if best is None:
        n0 = initial_interval(t, init_static_s)
        quiet = np.nanpercentile(moving_variance_norm(accel_raw, window_samples(t, window_s)), 10) \
            if len(t) > window_samples(t, window_s) else np.nan
        if np.linalg.norm(accel_raw[:n0].var(axis=0, ddof=1)) > 100 * quiet:
            # The thresholds are k times the variance of the first init_static_s: a record whose rest is shorter
            # moves inside that span, every window is 'static' and the poses merge into one; the count of
            # intervals then blames poses a user did record.
            raise CalibrationError(f"turntable-free: the first {init_static_s:g} s are not at rest (the unit moves "
                                   "in them); imu_tk's method takes its static threshold and the gyro bias from an "
                                   f"initial rest of {init_static_s:g} s, so record one before the first pose "
                                   "(or say the rest the recording has: `rig import ... --initial-rest-s S`)")
        if saturated:
            raise CalibrationError(f"turntable-free: fewer than {MIN_INTERVALS} static intervals left for every k in "
                                   f"{list(k_values)} once the {saturated} with a saturated accelerometer are left "
                                   f"out ({rail_names('accel', found, columns)}); record the poses within its range")
        raise CalibrationError(f"turntable-free: fewer than {MIN_INTERVALS} static intervals for every k in "
                               f"{list(k_values)}; record more poses held for >= {SAMPLES_PER_INTERVAL} samples")

    def rms(ranges) -> float:
        idx = np.concatenate([np.arange(a, b + 1) for a, b in ranges])
        norm = np.linalg.norm((accel_raw[idx] - best["B"]) @ best["H"].T, axis=1)
        return float(np.sqrt(np.mean((gravity - norm) ** 2)))

    warnings = [f"{rail_names('accel', found, columns)}: {best['saturated']} of "
                f"{best['saturated'] + len(best['intervals'])} static intervals read a sample at a rail and were left "
                "out of the fit "
                "(saturated: the pose's gravity beyond the range)"] if best["saturated"] else []
    if len(best["chunks"]) < IMU_TK_INTERVALS:
        warnings.append(f"only {len(best['chunks'])} static intervals for the accelerometer's 9 unknowns (imu_tk asks "
                        f"for at least {IMU_TK_INTERVALS}, Tedaldi et al. recommend 36-50): its fit has little to "
                        "spare against a pose placed badly")
    return TriadCalibration(B=best["B"], H=best["H"],
                            method="turntable-free-accel (imu_tk convention: upper-triangular H)",
                            residual_rms=rms(best["chunks"]), iterations=len(sweep), warnings=warnings,
                            extra={"k": best["k"], "cost": best["cost"],
                                   "fit_samples": [list(c) for c in best["chunks"]],
                                   "intervals": [list(c) for c in best["intervals"]],
                                   "residual_rms_full_intervals": rms(best["intervals"]), "k_sweep": sweep})


def unpinned(intervals: list[tuple[int, int]], pinned: np.ndarray) -> tuple[list[tuple[int, int]],
                                                                              list[tuple[int, int]]]:
    """The intervals with no sample at a rail, and those with one: a clipped pose reads less than its gravity (an
    axis at 8 m/s^2 where gravity along it gives 9.8), which the norm fit would take for scale. Leaving it out
    joins the motions either side of it into one, which still carries gravity from the pose before to the next."""
    if not pinned.any():
        return intervals, []
    spoiled = [(a, b) for a, b in intervals if pinned[a:b + 1].any()]
    return [iv for iv in intervals if iv not in spoiled], spoiled


def fit_accel_upper(chunks: list[np.ndarray], gravity: float) -> tuple[np.ndarray, np.ndarray, float]:
    """B, upper-triangular H and 1/2 sum (g - |H (y - B)|)^2 over the samples of static chunks [(m, 3)].

    The ellipsoid through the chunk means starts the fit; all samples are fitted (as imu_tk does).
    """
    samples = np.vstack(chunks)
    try:
        ell = fit_ellipsoid(np.array([c.mean(axis=0) for c in chunks]), min_spread=0.0)
        H0 = gravity * np.linalg.cholesky(ell.shape).T
        B0 = ell.center
    except (CalibrationError, np.linalg.LinAlgError):
        B0 = samples.mean(axis=0)
        H0 = gravity / np.median(np.linalg.norm(samples - B0, axis=1)) * np.eye(3)
    scale = float(np.abs(np.diag(H0)).mean())

    def residual(p: np.ndarray) -> np.ndarray:
        H = np.zeros((3, 3))
        H[UPPER] = p[3:] * scale
        return gravity - np.linalg.norm((samples - p[:3]) @ H.T, axis=1)

    res = minimise(residual, None, np.concatenate([B0, H0[UPPER] / scale]), tol=1e-12)
    H = np.zeros((3, 3))
    H[UPPER] = res.x[3:] * scale
    return res.x[:3], H, float(0.5 * res.fun @ res.fun)


def calibrate_gyro_gravity(t: np.ndarray, gyro_raw: np.ndarray, g_body: np.ndarray, intervals: list[tuple[int, int]],
                           init_static_s: float, columns: list[str] | None = None) -> TriadCalibration:
    """Gyro B from the initial rest, H from gravity directions carried across each move."""
    B = gyro_raw[:initial_interval(t, init_static_s)].mean(axis=0)
    g = g_body / np.linalg.norm(g_body, axis=1, keepdims=True)
    # Only a motion recorded whole carries gravity: a logger paused between poses (or one that lost a stretch of
    # rows) leaves a motion of a few samples either side of a gap, whose integral says nothing of the rotation;
    # fitted anyway, such motions gave an H hundreds of times too large with exit 0.
    whole = whole_motions(t, intervals)
    if not whole:
        raise CalibrationError(f"turntable-free gyro: none of the {len(intervals) - 1} motions between the rests was "
                               f"recorded whole (each has a gap of more than {GAP_FACTOR:g} sample periods); the "
                               "gyro's H needs the motions between the poses")
    whole, clipped, found = unclipped_motions(gyro_raw, intervals, whole)
    rail = rail_names("gyro", found, columns)
    if not whole:
        raise CalibrationError(f"turntable-free gyro: every one of the {len(clipped)} motions between the rests "
                               f"recorded whole reads a gyro sample at its rail ({rail}): saturated, its rate beyond "
                               "the range is lost; move slower or set a larger range")
    spans = [slice(intervals[i][1], intervals[i + 1][0] + 1) for i in whole]
    moves = [MoveStream(k, t[span], gyro_raw[span], np.eye(3), np.eye(3)) for k, span in enumerate(spans)]
    ms = MoveSet.build(moves, B)
    g0, g1 = g[whole], g[[i + 1 for i in whole]]

    def residuals(H: np.ndarray, moveset: MoveSet) -> np.ndarray:
        q = integrated_quats(H, moveset)          # R = R0^T R1 of each move, (..., n, 4)
        return _rotate_inverse(q, g0) - g1        # R^T g0 - g1

    s = _gyro_scale(moves, B, g0, g1)
    rest = gyro_raw[:initial_interval(t, init_static_s)]
    refuse_coarse_motions(None, "the unit", moves, B, _scale_bound(moves, B, g0, g1) * np.eye(3),
                          rest.std(axis=0, ddof=1), 1.0 / float(np.median(np.diff(t))))
    fun = lambda x: residuals(x.reshape(3, 3) * s, ms).ravel()

    def jac(x: np.ndarray, step: float = 1e-7) -> np.ndarray:
        X = np.vstack([x, x + step * np.eye(9)])
        r = residuals(X.reshape(-1, 3, 3) * s, ms).reshape(10, -1)
        return ((r[1:] - r[0]) / step).T

    res = minimise(fun, jac, np.eye(3).ravel(), tol=1e-12)
    rank = int(np.linalg.matrix_rank(res.jac))
    if rank < 9:
        left = f" ({len(clipped)} more were left out: {rail}, saturated)" if clipped else ""
        raise CalibrationError(f"turntable-free gyro: the {len(moves)} motions between the rests determine only {rank} "
                               f"of H's 9 entries{left}; record more motions between differently oriented poses")
    H = res.x.reshape(3, 3) * s
    r = res.fun
    cov = np.linalg.pinv(res.jac.T @ res.jac) * float(r @ r) / max(r.size - 9, 1) * s * s
    warnings = [] if np.linalg.det(H) > 0 else [f"det(H) = {np.linalg.det(H):.3g} <= 0"]
    if len(whole) + len(clipped) < len(intervals) - 1:
        warnings.append(f"{len(intervals) - 1 - len(whole) - len(clipped)} of {len(intervals) - 1} motions between "
                        "the rests have a gap in their samples and were left out of the gyro fit")
    if clipped:
        warnings.append(f"{rail}: {len(clipped)} of {len(clipped) + len(whole)} motions between the rests read a "
                        "sample at a rail and were left out of the fit (saturated: the rate beyond the range is lost)")
    rms = float(np.sqrt(np.mean(r * r)))
    if rms > POOR_FIT_UNIT:
        warnings.append(f"the gyro fit does not carry gravity between the rests: rms {rms:.3g} (unit vectors); "
                        "check that the rests are still and the gyro is sampled with the accelerometer")
    return TriadCalibration(B=B, H=H, method="turntable-free-gyro (gravity direction across moves, imu_tk)",
                            residual_rms=rms, iterations=int(res.nfev),
                            converged=bool(res.success), H_std=np.sqrt(np.clip(np.diag(cov), 0, None)).reshape(3, 3),
                            H_cov=cov, warnings=warnings,
                            extra={"moves": len(moves), "whole_motions": whole, "cost": float(0.5 * r @ r),
                                   "residual_unit": "unit gravity vector components"})


def whole_motions(t: np.ndarray, intervals: list[tuple[int, int]]) -> list[int]:
    """Indices i of the motions from rest i to rest i + 1 with no gap longer than GAP_FACTOR median sample
    periods."""
    dt = float(np.median(np.diff(t)))
    return [i for i, ((_, a_end), (b_start, _)) in enumerate(zip(intervals[:-1], intervals[1:]))
            if np.diff(t[a_end:b_start + 1]).max(initial=0.0) <= GAP_FACTOR * dt]


def unclipped_motions(gyro_raw: np.ndarray, intervals: list[tuple[int, int]], motions: list[int]
                      ) -> tuple[list[int], list[int], list]:
    """The motions (indices as `whole_motions`) with no gyro sample at a rail, those with one, and the rails: a
    clipped rate integrates to less than the turn, and a fit that carries gravity across it anyway scales H
    (a gyro clipped at 250 deg/s in hand motions came out 20 % off)."""
    found, hit = pinned_rows(gyro_raw)
    if not found:
        return motions, [], found
    clipped = [i for i in motions if hit[intervals[i][1]:intervals[i + 1][0] + 1].any()]
    return [i for i in motions if i not in clipped], clipped, found


def _rotate_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q)^T v for quaternions q (..., n, 4) and vectors v (n, 3)."""
    w, u = q[..., :1], -q[..., 1:]               # conj(q) rotates by R^T
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _scale_bound(moves: list[MoveStream], B: np.ndarray, g0: np.ndarray, g1: np.ndarray) -> float:
    """A lower bound of the gyro's scale that no integration enters: a motion turns at least the angle between
    the gravity directions it joins, and at most the scale times its raw rate's path."""
    path = np.array([np.sum(np.linalg.norm(m.y[1:] - B, axis=1) * np.diff(m.t)) for m in moves])
    turned = np.arccos(np.clip(np.sum(g0 * g1, axis=1), -1.0, 1.0))
    return float(np.max(turned / np.where(path > 0, path, np.inf)))


def _gyro_scale(moves: list[MoveStream], B: np.ndarray, g0: np.ndarray, g1: np.ndarray, stride: int = 4) -> float:
    """Scalar s with H = s I carrying gravity best, searched on every `stride`-th sample (a start point)."""
    ms = MoveSet.build(decimated(moves, stride), B)
    peak = float((np.linalg.norm(ms.S, axis=-1) / np.where(ms.h > 0, ms.h, np.inf)).max())

    def cost(svals: np.ndarray) -> np.ndarray:
        q = integrated_quats(np.asarray(svals)[:, None, None] * np.eye(3), ms)
        r = _rotate_inverse(q, g0) - g1
        return np.sum(r * r, axis=(-1, -2))

    return scalar_search(cost, np.radians(1.0) / peak, np.radians(3000.0) / peak)
