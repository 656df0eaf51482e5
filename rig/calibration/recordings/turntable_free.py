"""Calibration without known rotations (hand-held multi-position data such as imu_tk's Xsens set).

Follows imu_tk (Tedaldi et al., ICRA 2014), with our model `u = H (y - B)`:
* The initial rest (`static_detect.find_initial_rest`): the still stretch the record starts with, found in the data
  unless the recording says its length (imu_tk asks its user for 50 s). Its accelerometer variance is the unit of
  the static threshold and its gyro mean the gyro's bias; a record that starts moving takes the threshold from its
  quietest stretches and the bias from its poses.
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

from rig.calibration.numerics.ellipsoid import fit_ellipsoid
from rig.calibration.numerics.norm_fit_cov import stated_uncertainty
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.numerics.saturation import pinned_rows, rail_names
from rig.calibration.numerics.static_detect import (
    SAMPLES_PER_INTERVAL,
    InitialRest,
    detect_static_intervals,
    find_initial_rest,
    first_samples,
    long_intervals,
)
from rig.calibration.recordings.turntable_free_gyro import turntable_free_gyro
from rig.errors import CalibrationError

MIN_INTERVALS = 10          # the accelerometer's 9 unknowns and one pose to spare, so that its fit has a residual
IMU_TK_INTERVALS = 12       # imu_tk's own minimum: fewer is fitted, with a warning
NOT_AT_REST = 100.0         # a given initial rest whose accelerometer variance is this many times the rest found in
# the data (or the record's quiet level) holds a motion: its thresholds merge the poses
UPPER = np.triu_indices(3)
# The norm fit's evaluations at most. Fits the samples determine converge within 13 (measured over the recordings'
# tests: real and simulated, poses and quasi-static samples); the rest run off along a direction the samples leave
# free (Jacobian condition 1e7-1e13), to MINPACK's default of 900 evaluations, and their stated deviations refuse
# them either way.
NORM_FIT_MAX_NFEV = 100


class TooFewIntervals(CalibrationError):
    """Fewer than MIN_INTERVALS static intervals for every threshold: the record holds too few still poses (a
    record turned slowly without being set down is fitted otherwise, `quasi_static`). `intervals`: those of the
    threshold that found the most."""

    def __init__(self, message: str, intervals: list[tuple[int, int]]) -> None:
        super().__init__(message)
        self.intervals = intervals


def calibrate_turntable_free(t: np.ndarray, accel_raw: np.ndarray, gyro_raw: np.ndarray, *, gravity: float = 9.80665,
                             init_static_s: float | None = None, k_values: range | tuple = range(2, 11),
                             window_s: float = 1.0, columns: dict[str, list[str]] | None = None
                             ) -> dict[str, TriadCalibration]:
    """{'accel': ..., 'gyro': ...} from raw counts of a hand-held multi-position record (`turntable_free_accel`,
    then `turntable_free_gyro`); `init_static_s`: the initial rest's length where known (imu_tk's 50 s), else
    found in the data."""
    t, accel_raw, gyro_raw = np.asarray(t, dtype=float), checked(t, accel_raw, "accel"), checked(t, gyro_raw, "gyro")
    columns = columns or {}
    accel = turntable_free_accel(t, accel_raw, gravity=gravity, init_static_s=init_static_s, k_values=k_values,
                                 window_s=window_s, columns=columns.get("accel"), gyro_raw=gyro_raw)
    gyro = turntable_free_gyro(t, accel_raw, gyro_raw, accel, window_s=window_s, columns=columns.get("gyro"))
    return {"accel": accel, "gyro": gyro}


def describe_rest(accel_extra: dict) -> str:
    """What a turntable-free accelerometer's calibration took for the initial rest, in words."""
    origin = accel_extra.get("initial_rest", "none")
    return InitialRest(0, float(accel_extra.get("initial_rest_s", 0.0)), origin, 0.0).describe()


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
                         init_static_s: float | None = None, k_values: range | tuple = range(2, 11),
                         window_s: float = 1.0, columns: list[str] | None = None,
                         pose_means: bool = False, gyro_raw: np.ndarray | None = None) -> TriadCalibration:
    """The accelerometer of a hand-held multi-position record, imu_tk's way.

    The static threshold is k times the accelerometer's variance over the initial rest: `init_static_s` seconds
    where given, else the rest found in the data (with `gyro_raw`, the gyro's say too), else the record's quiet
    level (`static_detect.find_initial_rest`; `extra["initial_rest_s"]`, `extra["initial_rest"]`: "given",
    "found" or "none"). The record must hold at least MIN_INTERVALS poses for >= 100 samples each. `extra` holds
    the chosen k, the static intervals kept ("intervals"), the samples fitted ("fit_samples": the first 100 of each,
    as imu_tk, or every one with `pose_means`) and the whole k sweep; `residual_rms` is | |a| - g | over the fitted
    samples and `extra["residual_rms_full_intervals"]` over every sample of the intervals. Poses with a sample at a
    rail (saturated) are left out, named with the user's `columns` (['ax', 'ay', 'az']).
    """
    t, accel_raw = np.asarray(t, dtype=float), checked(t, accel_raw, "accel")
    if gyro_raw is not None:
        gyro_raw = checked(t, gyro_raw, "gyro")
    rest = find_initial_rest(t, accel_raw, gyro_raw, window_s=window_s, given_s=init_static_s)
    return _accel_sweep(t, accel_raw, gravity, rest, k_values, window_s, columns, pose_means)


def _accel_sweep(t: np.ndarray, accel_raw: np.ndarray, gravity: float, rest: InitialRest, k_values,
                 window_s: float, columns: list[str] | None = None, pose_means: bool = False) -> TriadCalibration:
    """imu_tk's threshold sweep: detect, fit, keep the k with the least cost."""
    best, sweep, most = None, [], []
    found, pinned = pinned_rows(accel_raw)
    saturated = 0
    for k in k_values:
        intervals = detect_static_intervals(t, accel_raw, window_s=window_s, threshold=k * rest.accel_level)
        intervals, spoiled = unpinned(intervals, pinned)
        chunks = first_samples(intervals, SAMPLES_PER_INTERVAL)
        saturated = max(saturated, len(long_intervals(spoiled, SAMPLES_PER_INTERVAL)))
        if len(chunks) > len(most):
            most = long_intervals(intervals, SAMPLES_PER_INTERVAL)
        if len(chunks) < MIN_INTERVALS:
            sweep.append({"k": k, "intervals": len(chunks), "cost": None})
            continue
        B, H, cost = fit_accel_upper([accel_raw[a:b + 1] for a, b in chunks], gravity, per_sample=True)
        sweep.append({"k": k, "intervals": len(chunks), "cost": cost})
        if best is None or cost < best["cost"]:
            best = {"k": k, "chunks": chunks, "intervals": long_intervals(intervals, SAMPLES_PER_INTERVAL),
                    "B": B, "H": H, "cost": cost, "saturated": len(long_intervals(spoiled, SAMPLES_PER_INTERVAL))}
    if best is None:
        if rest.origin == "given":
            # The thresholds are k times the variance of the rest said: a record whose rest is shorter moves inside
            # that span, every window is 'static' and the poses merge into one; the count of intervals then blames
            # poses a user did record.
            data = find_initial_rest(t, accel_raw, window_s=window_s)
            if rest.accel_level > NOT_AT_REST * data.accel_level:
                raise CalibrationError(f"turntable-free: the first {rest.seconds:g} s are not at rest (the unit moves "
                                       f"in them), though the recording says they are (initial_rest_s); the data show "
                                       f"{f'an initial rest of {data.seconds:.3g} s' if data.found else 'none'}: "
                                       "run rig import again without --initial-rest-s to take the rest from the data")
        if saturated:
            raise CalibrationError(f"turntable-free: fewer than {MIN_INTERVALS} static intervals left for every k in "
                                   f"{list(k_values)} once the {saturated} with a saturated accelerometer are left "
                                   f"out ({rail_names('accel', found, columns)}); record the poses within its range")
        raise TooFewIntervals(f"turntable-free: fewer than {MIN_INTERVALS} static intervals for every k in "
                              f"{list(k_values)}; record more poses held for >= {SAMPLES_PER_INTERVAL} samples", most)

    def rms(ranges) -> float:
        idx = np.concatenate([np.arange(a, b + 1) for a, b in ranges])
        norm = np.linalg.norm((accel_raw[idx] - best["B"]) @ best["H"].T, axis=1)
        return float(np.sqrt(np.mean((gravity - norm) ** 2)))

    warnings = [] if rest.found else [f"{rest.describe()}: the static threshold is taken from the record's quietest "
                                      "stretches rather than from a rest"]
    warnings += [f"{rail_names('accel', found, columns)}: {best['saturated']} of "
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
                                   **rest.to_extra(),
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
    imu_tk fits the first 100 samples of each interval instead, which leaves a left-out pose's mean further from g
    on poses held a few seconds (benchmarks/bench_recordings.py compares the two). The ellipsoid through the means
    starts the fit.
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

    def jacobian(p: np.ndarray) -> np.ndarray:
        """d(g - |v|)/dp with v = H (m - B): v^T H / |v| for B, -v_i (m - B)_j / |v| for each H_ij (x scale)."""
        H = np.zeros((3, 3))
        H[UPPER] = p[3:] * scale
        d = samples - p[:3]
        v = d @ H.T
        u = v / np.linalg.norm(v, axis=1)[:, None]
        return np.hstack([u @ H, -scale * u[:, UPPER[0]] * d[:, UPPER[1]]])

    res = least_squares(residual, np.concatenate([B0, H0[UPPER] / scale]), jac=jacobian, method="lm", xtol=1e-12,
                        ftol=1e-12, gtol=1e-12, max_nfev=NORM_FIT_MAX_NFEV)
    H = np.zeros((3, 3))
    H[UPPER] = res.x[3:] * scale
    return res.x[:3], H, float(0.5 * res.fun @ res.fun)
