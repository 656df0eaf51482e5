"""The statistics a recording is compared on with its simulated twin, each a named number.

Per sensor: the spread within each static pose, the pose means against the model (the accelerometer's |a| - g,
the gyro's calibrated rate), their scatter from pose to pose, the Allan deviation and the spectrum of the longest
pose, the step between the stream's distinct values (the grid's, where they lie on one), the share of samples
pinned at an extreme (the pose means only where there are several: a still log's one mean is what its
calibration was made from); per turn or motion the gyro's angle residual; the gyro's delay behind the accelerometer
and the magnetometer through the motions (`rig.noise.stream_delay`: what a turn's angle or a carried gravity, which
integrate through a delay, cannot show); and how the calibration's own standard deviations compare with the
scatter of leave-one-pose-out refits. The same function runs on the real recording
and on every replica, through the same calibration, so a difference is the world's, not the pipeline's.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.recordings.recording import RecordingCalibration
from rig.calibration.recordings.recording_fits import fit_faces
from rig.calibration.recordings.recording_vector import pose_stats
from rig.calibration.numerics.saturation import distinct as _distinct, pinned_ends
from rig.errors import CalibrationError
from rig.noise.allan import allan_deviation
from rig.noise.stream_delay import recording_delays
from rig.session_data import SessionData

AXES = "xyz"
PSD_BANDS = 4
LOO_POSES_MAX = 8
SPECTRUM_BATCH_SAMPLES = 1 << 18
# A grid fitted through thousands of printed values is known to ~1e-8 of its step, but two streams on one grid
# printed with different roundings (mikoff's accelerometer: g to 5 decimals, then m/s^2 to 5) differ there: five
# significant digits are what a step says, and all a twin can be asked to reproduce.
STEP_DIGITS = 5


def recording_statistics(session: SessionData, rec: RecordingCalibration) -> dict[str, float]:
    """Every statistic of `session` calibrated as `rec`, by name."""
    out: dict[str, float] = {}
    rate = _rate(session)
    longest = max(range(len(rec.poses)), key=lambda i: len(rec.poses[i].rows))
    for sensor in ("accel", "gyro", "mag"):
        if sensor not in session.raw or sensor not in rec.sensors:
            continue
        y = session.raw[sensor]
        cal = rec.sensors[sensor]
        complete = ~np.isnan(y).any(axis=1)
        in_pose = [_complete_rows(y, p.rows, complete) for p in rec.poses]
        for p, v in zip(rec.poses, in_pose):
            for k in range(3):
                out[f"{sensor}.spread.{AXES[k]}[{p.name}]"] = float(v[:, k].std(ddof=1))
        if len(rec.poses) > 1:        # one pose (a still log): its mean is what its calibration was made from
            out.update(_pose_means(session, rec, sensor, cal.apply(np.array([v.mean(axis=0) for v in in_pose]))))
        stretch = in_pose[longest]
        powers = _axis_powers(stretch, rate)
        for k in range(3):
            x = stretch[:, k]
            curve = allan_deviation(x, rate)
            for tau, adev in zip(curve.tau, curve.adev):
                out[f"{sensor}.adev.{AXES[k]}@{tau:.4g}s"] = float(adev)
            for (lo, hi), power in powers[k].items():
                out[f"{sensor}.psd.{AXES[k]}[{lo:.3g}-{hi:.3g} Hz]"] = power
            values, counts = _distinct(y[complete, k])      # one sort serves both
            out[f"{sensor}.step.{AXES[k]}"] = float(f"{_quantum(values, counts) or _step(values):.{STEP_DIGITS}g}")
            out[f"{sensor}.pinned.{AXES[k]}"] = _pinned(values, counts)
    gyro = rec.sensors.get("gyro")
    if gyro is not None:
        exact = gyro.extra.get("turns_fitted_exactly")      # three turns alone: their residuals are zero by design
        for turn, err in zip([] if exact else rec.turns, gyro.extra.get("turn_angle_error_deg", [])):
            out[f"gyro.turn_error[{turn.name}]"] = float(err)
        for (i, j), err in zip(rec.carries, gyro.extra.get("carry_error_deg", [])):
            out[f"gyro.carry_error[{rec.poses[i].name}->{rec.poses[j].name}]"] = float(err)
    for sensor, ratio in loo_scatter_ratios(session, rec).items():
        out[f"{sensor}.loo_scatter_to_predicted"] = ratio
    for sensor, delay in recording_delays(session, rec).items():
        out[f"gyro.lag_behind_{sensor}"] = delay.value
    return out


def _pose_means(session: SessionData, rec: RecordingCalibration, sensor: str, calibrated: np.ndarray
                ) -> dict[str, float]:
    """The calibrated pose means: the gyro's rates and their scatter from pose to pose, the other sensors' norms
    against the environment's where no face says which axis was up."""
    out = {}
    if sensor == "gyro":
        for p, m in zip(rec.poses, calibrated):
            for k in range(3):
                out[f"gyro.hold_mean.{AXES[k]}[{p.name}]"] = float(m[k])
        for k in range(3):
            out[f"gyro.bias_scatter.{AXES[k]}"] = float(calibrated[:, k].std(ddof=1))
        return out
    norm = session.gravity if sensor == "accel" else float(session.field_uT)
    residual = np.linalg.norm(calibrated, axis=1) - norm
    free = [i for i, p in enumerate(rec.poses) if not (sensor == "accel" and p.up)]
    for i in free:        # a face whose tilt is fitted meets |a| = g by construction: nothing to compare
        out[f"{sensor}.norm_residual[{rec.poses[i].name}]"] = float(residual[i])
    if len(free) > 2:
        out[f"{sensor}.norm_scatter"] = float(residual[free].std(ddof=1))
    return out


def band_powers(x: np.ndarray, rate: float) -> dict[tuple[float, float], float | np.ndarray]:
    """Mean Welch power spectral density in PSD_BANDS log-spaced bands from the lowest resolved frequency to
    Nyquist (unit^2 per Hz), of a stream x (n,), or of each row of x (m, n) in one call (an array per band)."""
    from scipy.signal import welch

    x = np.asarray(x, dtype=float)
    centred = x - x.mean() if x.ndim == 1 else np.stack([row - row.mean() for row in x])
    nper = int(min(256, x.shape[-1]))
    f, p = welch(centred, fs=rate, nperseg=nper, axis=-1)
    f, p = f[1:], p[..., 1:]
    edges = np.geomspace(f[0], f[-1] * (1 + 1e-9), PSD_BANDS + 1)
    out = {}
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (f >= lo) & (f < hi)
        if sel.any():
            out[(float(lo), float(hi))] = (float(p[sel].mean()) if x.ndim == 1
                                           else np.array([row[sel].mean() for row in p]))  # a row's sum, as 1-D
    return out


def _axis_powers(stretch: np.ndarray, rate: float) -> list[dict[tuple[float, float], float]]:
    """`band_powers` of each axis of a stretch (n, 3): the three in one call where the stretch is short (0.6 of the
    time of three calls), an axis at a time where it is long (a 6-hour log's detrended, windowed and transformed
    segments are about 100 MiB an axis, in each replica at once)."""
    if len(stretch) <= SPECTRUM_BATCH_SAMPLES:
        together = band_powers(stretch.T, rate)
        return [{band: float(p[k]) for band, p in together.items()} for k in range(3)]
    return [band_powers(stretch[:, k], rate) for k in range(3)]


def quantum(x: np.ndarray, share: float = 0.9) -> float:
    """The step of the grid a stream's values lie on (most of them: a few values off it, as a resampled row, do not
    undo it), or 0.0 where they lie on none: a stream in full precision has a smallest step too, set by how densely
    its values lie, which is no quantum."""
    return _quantum(*_distinct(x), share)


def _quantum(u: np.ndarray, n: np.ndarray, share: float = 0.9) -> float:
    """`quantum` of the distinct values u, seen n times each.

    The step is fitted to every distinct value, not read off the smallest gaps: a logger that prints counts times a
    scale with d decimals (mikoff's MPU-9150 logs, 5) rounds each gap by up to 10^-d, and a step read to 1e-5 of
    0.0048 misplaces the grid by several steps over the 4 000 between two faces. The gaps of 1 to 64 steps, summed
    over their count of steps, telescope the rounding away; a least-squares line through the distinct values against
    their step numbers then gives the step and the grid's origin (a value's distance from the line is its
    distance from the grid)."""
    q = _step(u)
    if q <= 0:
        return 0.0
    for _ in range(3):
        gaps = np.diff(u)
        k = np.round(gaps / q)
        whole = (k >= 1) & (k <= 64) & (np.abs(gaps / q - k) < 0.25)
        if not whole.any():
            return 0.0
        q = float(gaps[whole].sum() / k[whole].sum())
    steps = np.round((u - u[0]) / q)
    centred = steps - steps.mean()
    q = float(centred @ (u - u.mean()) / (centred @ centred)) if centred.any() else q
    r = (u - u.mean()) / q - centred
    return q if q > 0 and n[np.abs(r - np.round(r)) < 0.01].sum() >= share * n.sum() else 0.0


def pinned_fraction(x: np.ndarray) -> float:
    """Share of samples piled at the stream's smallest or largest value: a clipped output piles up at its rail,
    more there than at the value next to it; an unclipped one thins out towards its extremes (as
    pipeline.screening reads rails)."""
    return _pinned(*_distinct(x))


def _step(u: np.ndarray) -> float:
    if len(u) < 3:
        return 0.0
    gaps = np.diff(u)
    return float(np.median(np.sort(gaps)[: max(len(gaps) // 4, 1)]))


def _pinned(u: np.ndarray, n: np.ndarray) -> float:
    """Share of the samples at an extreme that `saturation.pinned_ends` calls piled up (the calibration leaves out
    what touched it; one definition for both)."""
    size = int(n.sum())
    if size < 3 or len(u) < 3:
        return 0.0
    low, high = pinned_ends(u, n)
    return float(((n[0] if low else 0) + (n[-1] if high else 0)) / size)


def loo_scatter_ratios(session: SessionData, rec: RecordingCalibration) -> dict[str, float]:
    """Per sensor, the jackknife scatter of its fitted parameters over leave-one-out refits against the standard
    deviations its fit states (median over the entries): about 1 where the stated uncertainty is honest. The
    accelerometer with faces refits without each pose; the norm-only accelerometer and the gyro (without each turn
    or motion, against the deviation of its own fit, before the share it inherits from the accelerometer's frame,
    which no refit of the gyro varies) take one Gauss-Newton step from their fit
    (`rig.calibration.numerics.jackknife`)."""
    out = {}
    accel, gyro = rec.sensors.get("accel"), rec.sensors.get("gyro")
    ratio = _faces_loo_ratio(session, rec)
    if ratio is None and accel is not None:
        ratio = (accel.extra.get("uncertainty") or {}).get("loo_scatter_to_predicted")
    if ratio is not None:
        out["accel"] = float(ratio)
    if gyro is not None and gyro.extra.get("loo_scatter_to_predicted") is not None:
        out["gyro"] = float(gyro.extra["loo_scatter_to_predicted"])
    return out


def _faces_loo_ratio(session: SessionData, rec: RecordingCalibration) -> float | None:
    """The accelerometer's with faces: refitted without each pose (at most LOO_POSES_MAX)."""
    accel = rec.sensors.get("accel")
    if accel is None or accel.H_std is None or not any(p.up for p in rec.poses):
        return None
    means, se, _ = pose_stats(session, "accel", rec.poses)
    ups = [p.up for p in rec.poses]
    tilt = np.radians([p.tilt_sd_deg for p in rec.poses])
    n = len(rec.poses)
    drop = range(n) if n <= LOO_POSES_MAX else np.linspace(0, n - 1, LOO_POSES_MAX).astype(int)
    fits = []
    for i in drop:
        keep = [j for j in range(n) if j != i]
        try:
            B, H, _, _ = fit_faces(means[keep], se[keep], [ups[j] for j in keep], tilt[keep], session.gravity)
        except CalibrationError:
            continue
        fits.append(np.r_[B, H.ravel()])
    if len(fits) < 3:
        return None
    fits = np.array(fits)
    m = len(fits)
    jack = np.sqrt((m - 1) / m * ((fits - fits.mean(axis=0)) ** 2).sum(axis=0))
    stated = np.r_[accel.B_std, np.asarray(accel.H_std).ravel()]
    ok = stated > 0
    return float(np.median(jack[ok] / stated[ok])) if ok.any() else None


def _complete_rows(y: np.ndarray, rows: np.ndarray, complete: np.ndarray) -> np.ndarray:
    """y's rows `rows` where every axis has a sample; a view where they are one unbroken run (a still log's one
    pose is the whole log: a copy of it was 52 MiB in each replica of a 6-hour log)."""
    if len(rows) and rows[-1] - rows[0] + 1 == len(rows) and complete[rows[0]:rows[-1] + 1].all():
        return y[rows[0]:rows[-1] + 1]
    return y[rows[complete[rows]]]


def _rate(session: SessionData) -> float:
    if session.sample_rate_hz:
        return float(session.sample_rate_hz)
    return float(1.0 / np.median(np.diff(session.t)))


