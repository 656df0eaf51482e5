"""The solvers of `rig.calibration` fed with the screened holds and moves of a session, and their results checked.

Accelerometer and magnetometer from the hold means and known rotations (joint or two-step), the gyroscope's
bias from the holds and its H from the moves, the accelerometer's lever arm from the move rows. A result that
cannot be right (non-finite, det(H) <= 0) is refused; one that may be wrong is a warning.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from rig.calibration.turntable import gyro, joint, lever_arm, observability, twostep
from rig.calibration.numerics.quantisation import QUANTISATION_STD, noise_sigma, rounding_bias_rms
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.turntable.sampling import (JITTER_SHARE, TABLE_MARGIN, move_timing, refuse_coarse_motions,
                                                rotation_steps)
from rig.errors import CalibrationError
from rig.pipeline.screening import trusted_moves
from rig.rotations import matrix_from_quat
from rig.session_data import HoldStats, MoveStream, SessionData
from rig.units import SENSOR_UNITS

METHODS = ("two-step", "joint")
MIN_HOLDS = {"two-step": 9,   # 9 parameters of the ellipsoid (twostep.MIN_ORIENTATIONS)
             "joint": 6}      # 14 parameters from 3 equations per hold (joint.MIN_ORIENTATIONS)
MIN_GYRO_MOVES = 3
COARSE_DEG_PER_SAMPLE = 4.0    # rotation between gyro samples above which integration error shows in H
# A gyro sample further than this many hold noise sigmas from the bias on any axis shows the table turning.
GYRO_STILL_SIGMAS = 6.0
RESIDUAL_WARN_FRACTION = 0.01   # accel/mag residual above 1 % of |g| or |m|


def calibrate_vector(session: SessionData, name: str, h: HoldStats, method: str,
                      warnings: list[str]) -> TriadCalibration:
    """Accelerometer (norm G) or magnetometer (norm M) from the hold means and rotations."""
    if name == "mag":
        if session.field_uT is None:
            raise CalibrationError(f"{session.source}: a magnetometer needs the local field magnitude field_uT")
        norm = float(session.field_uT)
    else:
        norm = float(session.gravity)
    need = MIN_HOLDS.get(method, max(MIN_HOLDS.values()))
    if len(h.step) < need:
        more = " (the joint method needs 6)" if method == "two-step" and len(h.step) >= MIN_HOLDS["joint"] else ""
        raise CalibrationError(f"{name}: {len(h.step)} usable orientations, need at least {need} for the "
                               f"{method} method{more}")
    if name == "accel":
        report = observability.check_schedule(h.R, min_orientations=need)
        if not report.ok:
            raise CalibrationError(f"accel: the hold schedule cannot calibrate: {report.message}")
    observability.require_spread(h.mean, name)
    if method == "joint":
        return joint.calibrate_joint(h.mean, h.R, norm, y_std=h.std, counts=h.count)
    solve = twostep.calibrate_two_step
    cal = solve(h.mean, h.R, norm)
    if cal.B_std is None and cal.H_std is None:
        try:
            cal.B_std, cal.H_std = jackknife_std(solve, h.mean, h.R, norm)
            cal.extra.setdefault("uncertainty", f"jackknife over {len(h.step)} holds")
        except CalibrationError as e:
            warnings.append(f"{name}: no uncertainty estimate ({e})")
    return cal


def jackknife_std(solve: Callable[..., TriadCalibration], y: np.ndarray, R: np.ndarray,
                  norm: float) -> tuple[np.ndarray, np.ndarray]:
    """Leave-one-hold-out standard deviations of B and H (Efron & Tibshirani, ch. 11, eq. 11.5).

    Why not the bootstrap: resampling with replacement repeats holds, and a set with fewer than nine
    distinct orientations leaves the ellipsoid underdetermined, which inflates the spread without bound.
    """
    n = len(y)
    fits = [solve(np.delete(y, i, axis=0), np.delete(R, i, axis=0), norm) for i in range(n)]
    Bs = np.array([f.B for f in fits])
    Hs = np.array([f.H for f in fits])
    scale = np.sqrt((n - 1) / n)
    return (scale * np.sqrt(((Bs - Bs.mean(axis=0)) ** 2).sum(axis=0)),
            scale * np.sqrt(((Hs - Hs.mean(axis=0)) ** 2).sum(axis=0)))


def calibrate_gyro_triad(session: SessionData, h: HoldStats, excluded: dict[int, str],
                    warnings: list[str], settle_s: float = 0.0, samples: str = "auto") -> TriadCalibration:
    """B from the still holds (eq. 41), H from the moves between trusted holds."""
    if len(h.step) < 1:
        raise CalibrationError("gyro: no usable hold to take the bias from")
    B = np.asarray(gyro.gyro_bias(h.mean, h.count), dtype=float)
    noise = np.maximum(np.median(h.std, axis=0), QUANTISATION_STD)
    moves = trusted_moves(session, excluded, warnings, settle_s, B, GYRO_STILL_SIGMAS * noise)
    if len(moves) < MIN_GYRO_MOVES:
        # A logger that writes only its holds leaves the gyro nothing to integrate: say so, not just "0 moves".
        why = "" if session.is_move.any() else " (the session has no 'move' rows: the gyro's H needs the moves)"
        raise CalibrationError(f"gyro: {len(moves)} usable moves between holds, need at least {MIN_GYRO_MOVES}{why}")
    check_move_axes(moves)
    nominal = gyro.path_bound(gyro.MoveSet.build(moves, B)) * np.eye(3)    # the comparison is relative: a scale will do
    refuse_coarse_motions(session.source, "the table", moves, B, nominal, noise, session.sample_rate_hz, TABLE_MARGIN)
    cal = gyro.calibrate_gyro(moves, B, samples=samples, rate_noise_counts=noise)
    warn_coarse_sampling(moves, cal, warnings)
    warn_irregular_sampling(moves, cal, warnings)
    if cal.B_std is None and len(h.step) > 1:
        # The holds see the same bias, so its rounding error does not average out over them.
        rounding = rounding_bias_rms(noise_sigma(h.std))
        cal.B_std = np.sqrt(h.mean.var(axis=0, ddof=1) / len(h.step) + rounding ** 2)
    return cal


def warn_coarse_sampling(moves: list[MoveStream], cal: TriadCalibration, warnings: list[str]) -> None:
    """Where the table's rate profile has a corner between two point samples, no interpolation knows where it
    was: the move's angle is off by up to a/8 dt^2. Measured on the second independent simulator: 5.7 deg per
    sample (200 deg/s on both axes at 50 Hz) leaves a gyro H error of up to 0.022 % with point samples (0.004 %
    with mean samples); 2.8 deg per sample (the same at 100 Hz) 0.005 %. A step across lost samples counts per
    sample period it spans: losing samples is not sampling slowly (`warn_irregular_sampling` says it)."""
    period = float(np.median(np.concatenate([np.diff(m.t) for m in moves])))
    worst = max(float(np.max(step / np.maximum(np.round(np.diff(m.t) / period), 1.0)))
                for step, m in zip(rotation_steps(moves, cal.B, cal.H), moves))
    if np.degrees(worst) > COARSE_DEG_PER_SAMPLE:
        warnings.append(f"gyro: the table turns up to {np.degrees(worst):.3g} deg between samples; above "
                        f"{COARSE_DEG_PER_SAMPLE:g} deg the integration between samples limits H to a few 0.01 % "
                        "(sample faster or move slower)")


def warn_irregular_sampling(moves: list[MoveStream], cal: TriadCalibration, warnings: list[str]) -> None:
    """Samples lost, or stamped away from the chip's sample instants, while the gyro turned: the moves' angles are
    off by the rate's change times the time error, and H with them
    (`rig.calibration.turntable.sampling.move_timing`)."""
    timing = move_timing(moves, cal.B, cal.H)
    if not timing.irregular:
        return
    said = []
    if timing.missing:
        said.append(f"{timing.missing} samples missing in {timing.holes} holes while the gyro turned (up to "
                    f"{1e3 * timing.longest_hole_s:.3g} ms, {timing.worst_hole_deg:.3g} deg across one)")
    if timing.jitter_s > JITTER_SHARE * timing.period_s:
        said.append(f"time stamps scattered by {1e3 * timing.jitter_s:.2g} ms RMS about the "
                    f"{1e3 * timing.period_s:.3g} ms sample period")
    warnings.append(f"gyro: the moves were sampled irregularly: {'; '.join(said)}. The integrated moves are off by "
                    "the rate's change times the time error, and H with them (0.1-0.3 % in the mixed rig at 400 "
                    "deg/s): the sampling loop fell behind the chip (a loaded host, a slow bus or table link)")


def check_move_axes(moves: list[MoveStream]) -> None:
    """The known rotations must turn the fixture about three independent axes, else H loses a column."""
    problem = observability.move_axes_problem(np.array([m.known_rotation for m in moves]))
    if problem:
        raise CalibrationError(f"gyro: {problem}")


def reference_norm(session: SessionData, name: str) -> float | None:
    return {"accel": session.gravity, "mag": session.field_uT}.get(name)


def check_result(name: str, cal: TriadCalibration, norm: float | None, warnings: list[str]) -> None:
    H, B = np.asarray(cal.H, dtype=float), np.asarray(cal.B, dtype=float)
    if H.shape != (3, 3) or B.shape != (3,) or not (np.isfinite(H).all() and np.isfinite(B).all()):
        raise CalibrationError(f"{name}: the solver returned a non-finite or misshapen B/H")
    det = float(np.linalg.det(H))
    if not det > 0:
        raise CalibrationError(f"{name}: det(H) = {det:.3g} <= 0 (a mirrored axis or a failed fit)")
    warnings.extend(f"{name}: {w}" for w in cal.warnings)
    if not cal.converged and not cal.warnings:
        warnings.append(f"{name}: the solver did not converge")
    if norm and np.isfinite(cal.residual_rms) and cal.residual_rms > RESIDUAL_WARN_FRACTION * norm:
        warnings.append(f"{name}: residual_rms {cal.residual_rms:.3g} {SENSOR_UNITS[name]} is "
                        f"{100 * cal.residual_rms / norm:.2g} % of the reference magnitude {norm:g}; check the holds")


def add_lever_arm(session: SessionData, sensors: dict[str, TriadCalibration], warnings: list[str]) -> None:
    """Locate the accelerometer relative to the table axes from the move rows (rig.calibration.turntable.lever_arm),
    stored under the accel calibration for the attitude filters. Sessions that do not sample the
    accelerometer during moves are left as they are; a failed fit is a warning, never a failed calibration.
    """
    if "accel" not in sensors or "gyro" not in sensors:
        return
    accel = sensors["accel"].apply(session.raw["accel"])
    rows = np.flatnonzero(session.is_move & np.isfinite(accel).all(axis=1))
    if len(rows) == 0:
        return
    try:
        gyro = sensors["gyro"].apply(session.raw["gyro"])
        fit = lever_arm.estimate_lever_arm(session.t, accel, gyro, matrix_from_quat(session.q_ref),
                                                         float(session.gravity), rows)
    except (ValueError, np.linalg.LinAlgError) as e:
        warnings.append(f"accel: no lever arm estimate ({e})")
        return
    sensors["accel"].extra.update({"lever_arm_m": [float(x) for x in fit.r_m],
                                   "lever_arm_std_m": [float(x) for x in fit.std_m],
                                   "lever_arm_significant": bool(fit.significant),
                                   "lever_arm_p_value": float(fit.p_value),
                                   "lever_arm_rows": int(fit.rows_used)})
