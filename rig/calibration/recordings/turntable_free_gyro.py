"""The gyroscope of a hand-held multi-position record without known rotations (imu_tk, Tedaldi et al. ICRA 2014).

B is the mean of the initial rest (eq. 41 on one hold; `static_detect.find_initial_rest`, which the
accelerometer's calibration names in its extra), or where the record starts moving, of the poses' still stretches.
The poses are the accelerometer's static intervals (`turntable_free`) cut where the gyro shows the unit turning
(`gyro_still`: a turn about the vertical leaves the accelerometer still, and a hand that lets a pose turn slowly is
still for the norm of gravity, not for the direction the gyro carries), those still for imu_tk's 100 samples kept.
H (full 3x3, mapping into the accelerometer's frame) makes the calibrated gyro, integrated from the end of one pose
to the start of the next, carry the gravity direction (calibrated accelerometer mean over the whole pose) of one
onto the next (`carried_gravity`: imu_tk's MultiPosGyroResidual). No rotation about gravity is seen by one move,
but the different poses make all of H observable.

H_std takes in what the motions share beside their noise: the integration error of the sample rate, the bias's
error and the accelerometer's (`carried_gravity`). Motions quick for their sample rate are calibrated with a
warning saying so; the gyro is refused only where the deviation H states, all that included, is more than a
calibration can be told to, or where integrating every second sample shows far more error than it covers
(`sampling.HandIntegration`).
"""

from __future__ import annotations

import numpy as np

from rig.calibration.recordings.carried_gravity import fit_carried_gravity, rotate_inverse
from rig.calibration.turntable.gyro import MoveSet, decimated, integrated_quats, scalar_search
from rig.calibration.recordings.gyro_still import GYRO_K, split_turning, turning_threshold
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.turntable.sampling import HandIntegration, coarseness
from rig.calibration.numerics.saturation import pinned_rows, rail_names
from rig.calibration.numerics.static_detect import SAMPLES_PER_INTERVAL, initial_interval, long_intervals
from rig.errors import CalibrationError
from rig.session_data import MoveStream

POOR_FIT_UNIT = 0.05        # rms gravity-direction misfit (unit vector components); imu_tk's Xsens fit: 0.012
GAP_FACTOR = 5.0            # a motion whose samples have a gap longer than this many sample periods is not whole


def turntable_free_gyro(t: np.ndarray, accel_raw: np.ndarray, gyro_raw: np.ndarray, accel: TriadCalibration, *,
                        window_s: float = 1.0, columns: list[str] | None = None) -> TriadCalibration:
    """The gyro from the poses the calibrated accelerometer `accel` found still (its extra "intervals"), cut where
    the gyro turns, and the initial rest it found or was told (its extra "initial_rest_s", "initial_rest");
    `extra["intervals"]` are the poses used, the motions between them its "whole_motions"."""
    found = [tuple(c) for c in accel.extra["intervals"]]
    rest_rows = initial_rest_rows(t, accel.extra)
    turning = turning_threshold(t, gyro_raw, window_s=window_s, rest_rows=rest_rows, poses=found)
    intervals = long_intervals(split_turning(t, gyro_raw, found, turning, window_s=window_s), SAMPLES_PER_INTERVAL)
    if len(intervals) < 2:
        raise CalibrationError(f"turntable-free gyro: of the accelerometer's {len(found)} static intervals, "
                               f"{len(intervals)} stay still for the gyro for {SAMPLES_PER_INTERVAL} samples "
                               f"(elsewhere it turns more than {GYRO_K:g} times the rest's rate): the poses were "
                               "not held still, and the motions between them cannot be told from the poses")
    pose_means = np.array([accel_raw[a:b + 1].mean(axis=0) for a, b in intervals])
    try:
        gyro = calibrate_gyro_gravity(t, gyro_raw, pose_means, intervals, rest_rows, columns, accel)
    except CalibrationError as exc:
        if len(intervals) == len(found):
            raise
        raise CalibrationError(f"{exc} (of the accelerometer's {len(found)} static intervals, {len(intervals)} stay "
                               f"still for the gyro for {SAMPLES_PER_INTERVAL} samples: elsewhere it turns more than "
                               f"{GYRO_K:g} times the rest's rate)") from None
    gyro.extra["intervals"] = [list(c) for c in intervals]
    return gyro


def initial_rest_rows(t: np.ndarray, accel_extra: dict) -> int:
    """Rows of the initial rest the accelerometer's calibration names (0 where the record starts moving)."""
    if accel_extra.get("initial_rest", "none") == "none":
        return 0
    return initial_interval(t, float(accel_extra["initial_rest_s"]))


def rest_bias(gyro_raw: np.ndarray, rest_rows: int, stills: list[tuple[int, int]]
              ) -> tuple[np.ndarray, np.ndarray, str]:
    """B, its standard deviation and where it came from: the initial rest's mean (imu_tk; white noise: its standard
    error), or where the record starts moving, the mean over the poses' still stretches (its deviation from the
    scatter of their means, which a hand's tremor and a g-sensitive gyro put beyond the noise)."""
    if rest_rows:
        rest = gyro_raw[:rest_rows]
        return rest.mean(axis=0), rest.std(axis=0, ddof=1) / np.sqrt(len(rest)), "initial rest"
    rows = np.concatenate([np.arange(a, b + 1) for a, b in stills])
    means = np.array([gyro_raw[a:b + 1].mean(axis=0) for a, b in stills])
    return gyro_raw[rows].mean(axis=0), means.std(axis=0, ddof=1) / np.sqrt(len(stills)), "poses"


def still_noise(gyro_raw: np.ndarray, rest_rows: int, stills: list[tuple[int, int]]) -> np.ndarray:
    """Per-axis standard deviation of the rate at rest (raw units): the initial rest's, or pooled over the poses'
    still stretches about each one's mean."""
    if rest_rows:
        return gyro_raw[:rest_rows].std(axis=0, ddof=1)
    dev = np.vstack([gyro_raw[a:b + 1] - gyro_raw[a:b + 1].mean(axis=0) for a, b in stills])
    return np.sqrt(np.sum(dev * dev, axis=0) / (len(dev) - len(stills)))


def calibrate_gyro_gravity(t: np.ndarray, gyro_raw: np.ndarray, pose_means: np.ndarray,
                           intervals: list[tuple[int, int]], rest_rows: int, columns: list[str] | None,
                           accel: TriadCalibration) -> TriadCalibration:
    """Gyro B from the initial rest (its first `rest_rows` rows; none: the poses), H from the gravity directions
    (the calibrated accelerometer's of the raw `pose_means`) carried across each move."""
    B, B_std, bias_from = rest_bias(gyro_raw, rest_rows, intervals)
    g_body = accel.apply(pose_means)
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
    g0, g1 = g[whole], g[[i + 1 for i in whole]]
    if 2 * len(moves) < 9:          # a motion carries a direction: two equations
        left = f" ({len(clipped)} more were left out: {rail}, saturated)" if clipped else ""
        raise CalibrationError(f"turntable-free gyro: the {len(moves)} motions between the rests determine at most "
                               f"{2 * len(moves)} of H's 9 entries{left}; record more motions between differently "
                               "oriented poses")
    s = _gyro_scale(moves, B, g0, g1)
    source = gravity_sensitivity(accel, pose_means[whole], pose_means[[i + 1 for i in whole]])
    fit = fit_carried_gravity(moves, B, np.diag(B_std ** 2), g0, g1, s, source)
    if fit.rank < 9:
        left = f" ({len(clipped)} more were left out: {rail}, saturated)" if clipped else ""
        raise CalibrationError(f"turntable-free gyro: the {len(moves)} motions between the rests determine only "
                               f"{fit.rank} of H's 9 entries{left}; record more motions between differently oriented "
                               "poses")
    H, cov, r = fit.H, fit.H_cov, fit.residuals.ravel()
    integration = HandIntegration(coarseness(moves, B, H, still_noise(gyro_raw, rest_rows, intervals)),
                                  diagonal_rel(cov, H), diagonal_rel(cov - fit.reading_cov, H),
                                  1.0 / float(np.median(np.diff(t))))
    if integration.refused:
        raise CalibrationError(f"gyro: {integration.refusal()}")
    warnings = [] if np.linalg.det(H) > 0 else [f"det(H) = {np.linalg.det(H):.3g} <= 0"]
    if integration.quick:
        warnings.append(integration.warning())
    if not rest_rows:
        warnings.append(f"no initial rest: bias from the poses ({len(intervals)} still stretches; the record starts "
                        "moving, where imu_tk takes it from a rest before the first pose)")
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
                            residual_rms=rms, iterations=fit.iterations,
                            converged=fit.converged, H_std=np.sqrt(np.clip(np.diag(cov), 0, None)).reshape(3, 3),
                            H_cov=cov, B_std=B_std, warnings=warnings,
                            extra={"moves": len(moves), "whole_motions": whole, "cost": float(0.5 * r @ r),
                                   "bias_from": bias_from,
                                   "integration": {"worst_step_deg": integration.found.worst_deg,
                                                   "step_doubling_rad": integration.found.error_rad,
                                                   "step_doubling_rel": integration.error_rel,
                                                   "stated_rel": integration.stated_rel,
                                                   "stated_rel_without": integration.without_rel,
                                                   "readings_disagree_rad": float(np.sqrt(np.mean(
                                                       fit.disagreement_rad ** 2))),
                                                   "shares": fit.shares.tolist(),
                                                   "shares_sd": fit.shares_sd.tolist()},
                                   "residual_unit": "unit gravity vector components"})


def gravity_sensitivity(accel: TriadCalibration, m0: np.ndarray, m1: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """d g / d p of the unit gravity directions g = H_a (m - B_a) / |.| of the raw pose means m0, m1 (n, 3) for the
    accelerometer's parameters p = (B_a, H_a row-major), and cov(p) from its B_cov and H_cov: the accelerometer's
    error turns the directions the gyro carries (its frame, and the poses' tilt within it)."""
    if accel.B_cov is None or accel.H_cov is None:
        return None
    p_cov = np.zeros((12, 12))
    p_cov[:3, :3], p_cov[3:, 3:] = accel.B_cov, accel.H_cov

    def jac(m: np.ndarray) -> np.ndarray:
        d = m - accel.B
        v = d @ accel.H.T
        norm = np.linalg.norm(v, axis=1)
        u = v / norm[:, None]
        P = (np.eye(3) - u[:, :, None] * u[:, None, :]) / norm[:, None, None]       # d unit(v) / d v
        dv_dB = -np.broadcast_to(accel.H, (len(m), 3, 3))
        dv_dH = np.einsum("ij,nk->nijk", np.eye(3), d).reshape(len(m), 3, 9)         # d v_i / d H_jk = delta_ij d_k
        return np.einsum("nij,njm->nim", P, np.concatenate([dv_dB, dv_dH], axis=2))

    return jac(m0), jac(m1), p_cov


def diagonal_rel(cov: np.ndarray, H: np.ndarray) -> float:
    """RMS standard deviation of H's diagonal from its covariance (9, 9), relative to its mean diagonal."""
    return float(np.sqrt(np.mean(np.clip(np.diag(cov)[[0, 4, 8]], 0, None))) / np.abs(np.diag(H)).mean())


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
        r = rotate_inverse(q, g0) - g1
        return np.sum(r * r, axis=(-1, -2))

    return scalar_search(cost, np.radians(1.0) / peak, np.radians(3000.0) / peak)
