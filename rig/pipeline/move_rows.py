"""The accelerometer's and magnetometer's move samples fed to `rig.calibration.turntable.move_samples`.

Which rows: those of the moves between two used holds (not touching an excluded hold, not across a resumed
run), where the sensor has a sample and the reference is finite, and where the reference agrees with the
gyro. A move's reference is the table's encoder polls interpolated between them; where it is stale (a row
that repeats the last poll while the table turns) or off (the interpolation rounding a corner of the rate
profile between two polls), its rate and the calibrated gyro's disagree, and those rows are left out.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.turntable.joint import hold_sigma
from rig.calibration.turntable.lever_arm import lever_arm_matrix, rate_and_derivative
from rig.calibration.turntable.move_samples import MoveSamples, calibrate_with_moves
from rig.calibration.numerics.quantisation import QUANTISATION_STD, noise_sigma, rounding_bias_rms
from rig.calibration.numerics.result import TriadCalibration
from rig.errors import CalibrationError
from rig.pipeline.screening import resume_times
from rig.quaternions import matrix_from_quat, rotvec_from_matrix
from rig.session_data import HoldStats, SessionData

# A row whose reference rate differs from the gyro's (averaged over RATE_SMOOTH rows) by more than this many
# of the gyro's per-sample noise, or RATE_FLOOR_RAD_S, has a reference that is stale or off.
RATE_SIGMAS = 6.0
RATE_FLOOR_RAD_S = 0.02
RATE_SMOOTH = 3
MIN_ROWS = 50
GAP_PERIODS = 1.5
STILL_RAD_S = 0.01          # a reference turning slower than this stands still (as MoveStream.trimmed_to_motion)
# Where the rounding bias of a still reading is this share of a sample's noise or more, the still rows of a move
# (the settling before the next hold) carry the hold's own bias and are left out: averaging them as independent
# samples would claim an accuracy the rounding does not allow.
ROUNDING_SHARE = 0.1


def move_spans(session: SessionData, excluded: dict[int, str], settle_s: float) -> list[np.ndarray]:
    """Row indices of each usable move: strictly between the last row of a used hold and the first settled row
    of the next (the move's rows and the next hold's settling time, whose reference is the hold's own: where
    the table still rings there, the gyro shows it and the rows are left out)."""
    holds = session.hold_rows(settle_s)
    resumes = resume_times(session)
    out = []
    for (j, a), (k, b) in zip(holds[:-1], holds[1:]):
        if j in excluded or k in excluded:
            continue
        t0, t1 = session.t[a[-1]], session.t[b[0]]
        if any(t0 <= r <= t1 for r in resumes):
            continue
        out.append(np.arange(a[-1] + 1, b[0]))
    return [r for r in out if r.size]


def stretch_labels(t: np.ndarray) -> np.ndarray:
    """Label of each row's stretch of uninterrupted sampling: a new stretch after every gap of more than
    GAP_PERIODS sample periods (a stalled read, a redone step, a resumed run). A chip on its own sample clock keeps
    its phase to the rig's tick grid within a stretch, so each stretch gets one sample-time offset."""
    dt = np.diff(t)
    if not len(dt):
        return np.zeros(len(t), dtype=int)
    return np.concatenate([[0], np.cumsum(dt > GAP_PERIODS * np.median(dt))])


def reference_rate(t: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Body rate (rad/s, fixture frame) of the reference rows R (m, 3, 3) at times t: central differences."""
    if len(t) < 3:
        return np.zeros((len(t), 3))
    i0 = np.r_[0, np.arange(len(t) - 2), len(t) - 2]
    i1 = np.r_[1, np.arange(2, len(t)), len(t) - 1]
    step = rotvec_from_matrix(np.einsum("kji,kjl->kil", R[i0], R[i1]))
    return step / (t[i1] - t[i0])[:, None]


def refine_vector_with_moves(session: SessionData, holds: dict[str, HoldStats], sensors: dict[str, TriadCalibration],
                             excluded: dict[int, str], warnings: list[str], settle_s: float) -> None:
    """Refit the accelerometer and magnetometer (joint fits only) with their move samples; a fit that fails or a
    session without usable move rows keeps the hold-only fit (with a warning where a fit failed)."""
    if "gyro" not in sensors:
        return
    spans = move_spans(session, excluded, settle_s)
    if not spans:
        return
    rows = np.concatenate(spans)
    gyro_cal = sensors["gyro"]
    try:
        with np.errstate(invalid="ignore"):
            R = matrix_from_quat(session.q_ref[rows])
            ok = np.isfinite(R).all(axis=(1, 2))
            omega_ref = np.zeros((len(rows), 3))
            for s in np.split(np.arange(len(rows)), np.cumsum([len(sp) for sp in spans])[:-1]):
                omega_ref[s] = reference_rate(session.t[rows[s]], R[s])
        w_all, dw_all = rate_and_derivative(session.t, gyro_cal.apply(session.raw["gyro"]))
    except (ValueError, np.linalg.LinAlgError) as e:
        warnings.append(f"accel, mag: the move samples were not used ({e}); B and H from the holds alone")
        return
    w, dw = w_all[rows], dw_all[rows]
    move = stretch_labels(session.t)[rows]
    gyro_sd = float(np.sqrt(np.mean(np.square(holds["gyro"].std @ gyro_cal.H.T)))) if len(holds["gyro"].step) else 0.0
    with np.errstate(invalid="ignore"):
        mismatch = np.linalg.norm(_smooth(w - omega_ref, spans), axis=1)
    agree = mismatch <= max(RATE_SIGMAS * gyro_sd / np.sqrt(RATE_SMOOTH), RATE_FLOOR_RAD_S)
    for name in ("accel", "mag"):
        cal = sensors.get(name)
        h = holds.get(name)
        if cal is None or h is None or "reference_world" not in cal.extra or not cal.method.startswith("joint"):
            continue
        y = session.raw[name][rows]
        use = ok & agree & np.isfinite(y).all(axis=1)
        if use.sum() < MIN_ROWS:
            continue
        sigma = np.maximum(np.sqrt(np.mean(np.square(h.std), axis=0)), QUANTISATION_STD)
        if np.any(rounding_bias_rms(noise_sigma(h.std)) > ROUNDING_SHARE * sigma):
            use &= np.linalg.norm(omega_ref, axis=1) >= STILL_RAD_S
            if use.sum() < MIN_ROWS:
                continue
        extra = np.zeros((int(use.sum()), 3))
        arm = cal.extra.get("lever_arm_m") if name == "accel" else None
        if arm is not None and cal.extra.get("lever_arm_significant"):     # as the attitude comparison applies it
            extra = np.einsum("kab,b->ka", lever_arm_matrix(w[use], dw[use]), np.asarray(arm, dtype=float))
        samples = MoveSamples(y[use], R[use], omega_ref[use], extra, sigma, move[use])
        norm = float(session.gravity if name == "accel" else session.field_uT)
        try:
            fit = calibrate_with_moves(cal, h.mean, h.R, hold_sigma(h.std, h.count, len(h.step)), norm, samples)
        except (CalibrationError, np.linalg.LinAlgError) as e:
            warnings.append(f"{name}: the move samples were not used ({e}); B and H from the holds alone")
            continue
        fit.extra["move_rows_left_out"] = int(len(rows) - use.sum() - (~np.isfinite(y).all(axis=1)).sum())
        sensors[name] = fit


def _smooth(a: np.ndarray, spans: list[np.ndarray]) -> np.ndarray:
    """Running mean over RATE_SMOOTH rows within each move."""
    out = np.empty_like(a)
    start = 0
    for sp in spans:
        seg = a[start:start + len(sp)]
        k = min(RATE_SMOOTH, len(seg))
        kernel = np.ones(k) / k
        out[start:start + len(sp)] = np.column_stack([np.convolve(seg[:, i], kernel, mode="same") for i in range(3)])
        start += len(sp)
    return out
