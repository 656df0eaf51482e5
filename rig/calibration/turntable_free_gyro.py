"""The gyroscope of a hand-held multi-position record without known rotations (imu_tk, Tedaldi et al. ICRA 2014).

B is the mean of the initial static interval (eq. 41 on one hold). The poses are the accelerometer's static
intervals (`turntable_free`) cut where the gyro shows the unit turning (`gyro_still`: a turn about the vertical
leaves the accelerometer still, and a hand that lets a pose turn slowly is still for the norm of gravity, not for
the direction the gyro carries), those still for imu_tk's 100 samples kept. H (full 3x3, mapping into the
accelerometer's frame) makes the calibrated gyro, integrated from the end of one pose to the start of the next,
carry the gravity direction (calibrated accelerometer mean over the whole pose) of one onto the next: residual
R^T g0 - g1 on unit vectors, as imu_tk's MultiPosGyroResidual. No rotation about gravity is seen by one move, but
the different poses make all of H observable.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.gyro import MoveSet, decimated, integrated_quats, scalar_search
from rig.calibration.gyro_still import GYRO_K, split_turning, turning_threshold
from rig.calibration.result import TriadCalibration
from rig.calibration.sampling import refuse_coarse_motions
from rig.calibration.saturation import pinned_rows, rail_names
from rig.calibration.static_detect import SAMPLES_PER_INTERVAL, initial_interval, long_intervals
from rig.errors import CalibrationError
from rig.session_data import MoveStream

POOR_FIT_UNIT = 0.05        # rms gravity-direction misfit (unit vector components); imu_tk's Xsens fit: 0.012
GAP_FACTOR = 5.0            # a motion whose samples have a gap longer than this many sample periods is not whole


def turntable_free_gyro(t: np.ndarray, accel_raw: np.ndarray, gyro_raw: np.ndarray, accel: TriadCalibration, *,
                        init_static_s: float, window_s: float = 1.0, columns: list[str] | None = None
                        ) -> TriadCalibration:
    """The gyro from the poses the calibrated accelerometer `accel` found still (its extra "intervals"), cut where
    the gyro turns; `extra["intervals"]` are the poses it used, the motions between them its "whole_motions"."""
    found = [tuple(c) for c in accel.extra["intervals"]]
    turning = turning_threshold(t, gyro_raw, window_s=window_s, init_static_s=init_static_s)
    intervals = long_intervals(split_turning(t, gyro_raw, found, turning, window_s=window_s), SAMPLES_PER_INTERVAL)
    if len(intervals) < 2:
        raise CalibrationError(f"turntable-free gyro: of the accelerometer's {len(found)} static intervals, "
                               f"{len(intervals)} stay still for the gyro for {SAMPLES_PER_INTERVAL} samples "
                               f"(elsewhere it turns more than {GYRO_K:g} times the initial rest's rate): the poses were "
                               "not held still, and the motions between them cannot be told from the poses")
    g_body = accel.apply(np.array([accel_raw[a:b + 1].mean(axis=0) for a, b in intervals]))
    try:
        gyro = calibrate_gyro_gravity(t, gyro_raw, g_body, intervals, init_static_s, columns)
    except CalibrationError as exc:
        if len(intervals) == len(found):
            raise
        raise CalibrationError(f"{exc} (of the accelerometer's {len(found)} static intervals, {len(intervals)} stay "
                               f"still for the gyro for {SAMPLES_PER_INTERVAL} samples: elsewhere it turns more than "
                               f"{GYRO_K:g} times the initial rest's rate)") from None
    gyro.extra["intervals"] = [list(c) for c in intervals]
    return gyro


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

    if 2 * len(moves) < 9:          # a motion carries a direction: two equations
        left = f" ({len(clipped)} more were left out: {rail}, saturated)" if clipped else ""
        raise CalibrationError(f"turntable-free gyro: the {len(moves)} motions between the rests determine at most "
                               f"{2 * len(moves)} of H's 9 entries{left}; record more motions between differently "
                               "oriented poses")
    s = _gyro_scale(moves, B, g0, g1)
    rest = gyro_raw[:initial_interval(t, init_static_s)]
    refuse_coarse_motions(None, "the unit", moves, B, _scale_bound(moves, B, g0, g1) * np.eye(3),
                          rest.std(axis=0, ddof=1), 1.0 / float(np.median(np.diff(t))))
    fun = lambda x: residuals(x.reshape(3, 3) * s, ms).ravel()

    def jac(x: np.ndarray, step: float = 1e-7) -> np.ndarray:
        X = np.vstack([x, x + step * np.eye(9)])
        r = residuals(X.reshape(-1, 3, 3) * s, ms).reshape(10, -1)
        return ((r[1:] - r[0]) / step).T

    res = least_squares(fun, np.eye(3).ravel(), jac=jac, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12)
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
