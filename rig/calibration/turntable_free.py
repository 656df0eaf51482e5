"""Calibration without known rotations (hand-held multi-position data such as imu_tk's Xsens set).

Follows imu_tk (Tedaldi et al., ICRA 2014), with our model `u = H (y - B)`:
* Accelerometer (here): static intervals detected from the data for k = 2..10 (imu_tk's sweep); for
  each k the first 100 samples of every interval longer than that are fitted to `|H (y - B)| = g` with H upper
  triangular (imu_tk's convention: the accelerometer frame *is* the body frame, no rotation is
  observable without known orientations); start from the algebraic ellipsoid (`fit_ellipsoid`),
  whose shape matrix A = U^T U gives the upper-triangular start H = g U directly. The k with the
  lowest final cost (1/2 sum r^2, as imu_tk) wins. With `pose_means` (a recording's calibration, not imu_tk's
  method), its intervals are then fitted by their means over all their samples, one weight per pose. A pose that
  turns slowly, or two poses and a turn about the vertical between them, keep |a| = g: the accelerometer's fit takes
  imu_tk's intervals as they are.
* Gyroscope (`turntable_free_gyro`): the same intervals cut where the gyro shows the unit turning, and H carrying
  the gravity direction of each across the motion to the next.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.ellipsoid import fit_ellipsoid
from rig.calibration.norm_fit_cov import stated_uncertainty
from rig.calibration.result import TriadCalibration
from rig.calibration.saturation import pinned_rows, rail_names
from rig.calibration.static_detect import (
    SAMPLES_PER_INTERVAL,
    detect_static_intervals,
    first_samples,
    initial_interval,
    long_intervals,
    moving_variance_norm,
    window_samples,
)
from rig.calibration.turntable_free_gyro import turntable_free_gyro
from rig.errors import CalibrationError

MIN_INTERVALS = 10          # the accelerometer's 9 unknowns and one pose to spare, so that its fit has a residual
IMU_TK_INTERVALS = 12       # imu_tk's own minimum: fewer is fitted, with a warning
INITIAL_REST_S = 50.0       # imu_tk's initial static interval, unless the recording says its own (initial_rest_s)
UPPER = np.triu_indices(3)


def calibrate_turntable_free(t: np.ndarray, accel_raw: np.ndarray, gyro_raw: np.ndarray, *, gravity: float = 9.80665,
                             init_static_s: float = INITIAL_REST_S, k_values: range | tuple = range(2, 11),
                             window_s: float = 1.0, columns: dict[str, list[str]] | None = None
                             ) -> dict[str, TriadCalibration]:
    """{'accel': ..., 'gyro': ...} from raw counts of a hand-held multi-position record (`turntable_free_accel`,
    then `turntable_free_gyro`)."""
    t, accel_raw, gyro_raw = np.asarray(t, dtype=float), checked(t, accel_raw, "accel"), checked(t, gyro_raw, "gyro")
    columns = columns or {}
    accel = turntable_free_accel(t, accel_raw, gravity=gravity, init_static_s=init_static_s, k_values=k_values,
                                 window_s=window_s, columns=columns.get("accel"))
    gyro = turntable_free_gyro(t, accel_raw, gyro_raw, accel, init_static_s=init_static_s, window_s=window_s,
                               columns=columns.get("gyro"))
    return {"accel": accel, "gyro": gyro}


def checked(t: np.ndarray, y: np.ndarray, name: str) -> np.ndarray:
    """y (n, 3) as floats, refused (ValueError naming the sensor and row) if its shape or a value is wrong."""
    y = np.asarray(y, dtype=float)
    if y.shape != (len(t), 3):
        raise ValueError(f"turntable-free: {name} must have shape ({len(t)}, 3), got {y.shape}")
    if not np.all(np.isfinite(y)):
        row = int(np.flatnonzero(~np.isfinite(y).all(axis=1))[0])
        raise ValueError(f"turntable-free: {name} contains NaN/inf at row {row}")
    return y


def turntable_free_accel(t: np.ndarray, accel_raw: np.ndarray, *, gravity: float = 9.80665,
                         init_static_s: float = INITIAL_REST_S, k_values: range | tuple = range(2, 11),
                         window_s: float = 1.0, columns: list[str] | None = None,
                         pose_means: bool = False) -> TriadCalibration:
    """The accelerometer of a hand-held multi-position record, imu_tk's way.

    The record must start with `init_static_s` seconds at rest (the threshold) and hold at least MIN_INTERVALS
    poses for >= 100 samples each. `extra` holds the chosen k, the static intervals kept ("intervals"), the samples
    fitted ("fit_samples": the first 100 of each, as imu_tk, or every one with `pose_means`) and the whole k sweep;
    `residual_rms` is | |a| - g | over the fitted samples and `extra["residual_rms_full_intervals"]` over every
    sample of the intervals. Poses
    with a sample at a rail (saturated) are left out, named with the user's `columns` (['ax', 'ay', 'az']).
    """
    return _accel_sweep(np.asarray(t, dtype=float), checked(t, accel_raw, "accel"), gravity, init_static_s,
                        k_values, window_s, columns, pose_means)


def _accel_sweep(t: np.ndarray, accel_raw: np.ndarray, gravity: float, init_static_s: float, k_values,
                 window_s: float, columns: list[str] | None = None, pose_means: bool = False) -> TriadCalibration:
    """imu_tk's threshold sweep: detect, fit, keep the k with the least cost."""
    best, sweep = None, []
    found, pinned = pinned_rows(accel_raw)
    saturated = 0
    for k in k_values:
        intervals = detect_static_intervals(t, accel_raw, window_s=window_s, init_static_s=init_static_s, k=k)
        intervals, spoiled = unpinned(intervals, pinned)
        chunks = first_samples(intervals, SAMPLES_PER_INTERVAL)
        saturated = max(saturated, len(long_intervals(spoiled, SAMPLES_PER_INTERVAL)))
        if len(chunks) < MIN_INTERVALS:
            sweep.append({"k": k, "intervals": len(chunks), "cost": None})
            continue
        B, H, cost = fit_accel_upper([accel_raw[a:b + 1] for a, b in chunks], gravity, per_sample=True)
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
    fitted = best["intervals"] if pose_means else best["chunks"]
    poses = [accel_raw[a:b + 1] for a, b in fitted]
    if pose_means:
        best["B"], best["H"], _ = fit_accel_upper(poses, gravity)
    spread, basis, few = stated_uncertainty(poses, best["B"], best["H"], gravity)
    return TriadCalibration(B=best["B"], H=best["H"],
                            method="turntable-free-accel (imu_tk convention: upper-triangular H"
                                   + ("; each pose's mean)" if pose_means else ")"),
                            residual_rms=rms(fitted), iterations=len(sweep), warnings=warnings + few,
                            **spread, extra={"k": best["k"], "cost": best["cost"], "uncertainty": basis,
                                   "fit_samples": [list(c) for c in fitted],
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


def fit_accel_upper(chunks: list[np.ndarray], gravity: float, per_sample: bool = False
                    ) -> tuple[np.ndarray, np.ndarray, float]:
    """B, upper-triangular H and 1/2 sum (g - |H (m - B)|)^2 over the means m of static chunks [(n, 3)]; with
    `per_sample`, over their samples, as imu_tk fits (its cost chooses the static threshold).

    A pose's evidence about H is its mean (`norm_fit_cov`): each pose weighs the same and brings all its samples.
    imu_tk fits the first 100 samples of each interval instead; on mikoff/imu-calib's five MPU-9150 sessions
    (poses held 3-10 s) its fit left the mean of a left-out pose 1.4-2.5 times further from g than this one (README,
    "Beside the peers"). The ellipsoid through the means starts the fit.
    """
    means = np.array([c.mean(axis=0) for c in chunks])
    samples = np.vstack(chunks) if per_sample else means
    try:
        ell = fit_ellipsoid(means, min_spread=0.0)
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

    res = least_squares(residual, np.concatenate([B0, H0[UPPER] / scale]), method="lm", xtol=1e-12, ftol=1e-12,
                        gtol=1e-12)
    H = np.zeros((3, 3))
    H[UPPER] = res.x[3:] * scale
    return res.x[:3], H, float(0.5 * res.fun @ res.fun)
