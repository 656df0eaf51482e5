"""Calibrate a whole measured session: what `rig calibrate --from DIR --out OUT` runs.

The solvers in `rig.calibration` are pure functions on hold means and move streams. This module
decides what they are fed: it drops the settling time of each hold, refuses data that cannot give a
trustworthy matrix (too few or coplanar orientations, a schedule that never excites an axis, NaN),
and removes holds that were not still (a hold's noise far above the others', a gyro mean far from
the bias) or that touch a saturated rail, naming each step it drops. The rule throughout: a clear
error or a flagged warning, never a silently wrong matrix.
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from rig.calibration.quantisation import QUANTISATION_STD, noise_sigma, rounding_bias_rms
from rig.calibration.result import TriadCalibration
from rig.errors import CalibrationError
from rig.rotations import matrix_from_quat
from rig.session_data import SENSOR_UNITS, HoldStats, MoveStream, SessionData

METHODS = ("two-step", "joint")
MIN_HOLDS = {"two-step": 9,   # 9 parameters of the ellipsoid (twostep.MIN_ORIENTATIONS)
             "joint": 6}      # 14 parameters from 3 equations per hold (joint.MIN_ORIENTATIONS)
MIN_GYRO_MOVES = 3
COARSE_DEG_PER_SAMPLE = 4.0    # rotation between gyro samples above which integration error shows in H
# A hold whose noise (norm of the per-axis std) exceeds this multiple of the median hold's, plus
# one count for quantised, nearly noiseless sensors, was not still.
MOTION_STD_FACTOR = 5.0
MOTION_STD_FLOOR_COUNTS = 1.0
# A gyro hold mean further than this many robust sigmas from the bias, and by more than the half count that
# the mean of quantised samples without noise to dither them can be off anyway, was turning.
GYRO_MEAN_SIGMAS = 6.0
GYRO_MEAN_FLOOR_COUNTS = 0.5
# A gyro sample further than this many hold noise sigmas from the bias on any axis shows the table turning.
GYRO_STILL_SIGMAS = 6.0
# Rotation vectors of the moves must span 3-D, else one gyro axis is never excited.
RESIDUAL_WARN_FRACTION = 0.01   # accel/mag residual above 1 % of |g| or |m|
DEFAULT_GRAVITY = 9.80665


@dataclass
class SessionCalibration:
    """Per-sensor calibrations of one session plus what the user must know about how they were made."""

    sensors: dict[str, TriadCalibration]
    warnings: list[str] = field(default_factory=list)
    summary: list[str] = field(default_factory=list)
    excluded_steps: dict[int, str] = field(default_factory=dict)
    holds_used: dict[str, int] = field(default_factory=dict)


def calibrate_session(session: SessionData, *, method: str = "joint", settle_s: float = 0.5,
                      gyro_samples: str = "auto") -> SessionCalibration:
    """Calibrate every sensor of `session`; raises CalibrationError where the data cannot support it.

    gyro_samples: what a raw gyro sample means, "point" or "mean" (gyro.calibrate_gyro), or "auto".
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    _check_finite(session)
    warnings: list[str] = []
    if settle_s > 0:
        warnings.append(f"dropped the first {settle_s:g} s of every hold as settling")
    _warn_partial_nan(session, warnings)
    holds = {s: session.holds(s, settle_s) for s in session.sensors}
    _warn_empty_holds(session, holds, settle_s, warnings)
    excluded = _find_bad_holds(session, holds, settle_s)
    for step, reason in sorted(excluded.items()):
        warnings.append(f"step {step}: excluded, {reason}")
    holds = {s: _without_steps(h, excluded) for s, h in holds.items()}

    sensors: dict[str, TriadCalibration] = {}
    for name in session.sensors:
        if name == "gyro":
            sensors[name] = _calibrate_gyro(session, holds[name], excluded, warnings, settle_s, gyro_samples)
        else:
            sensors[name] = _calibrate_vector(session, name, holds[name], method, warnings)
        _check_result(name, sensors[name], _reference_norm(session, name), warnings)
    _add_lever_arm(session, sensors, warnings)
    result = SessionCalibration(sensors, warnings, excluded_steps=excluded,
                                holds_used={s: len(h.step) for s, h in holds.items()})
    result.summary = summary_lines(result)
    return result


def calibrate_from_dir(session_dir: str | os.PathLike | None, out_dir: str | os.PathLike, *, fmt: str = "interchange",
                       accel_file: str | os.PathLike | None = None, gyro_file: str | os.PathLike | None = None,
                       method: str = "joint", settle_s: float = 0.5, gravity: float | None = None,
                       gyro_samples: str = "auto",
                       unit_serial: str | None = None, board: str | None = None,
                       echo: Callable[[str], None] = print) -> SessionCalibration:
    """Read a session folder, calibrate it, write `OUT/calibration.json`, echo a short summary.

    fmt "interchange": `session_dir` is an `imu-session-csv/1` folder; `gravity` overrides its meta.
    fmt "imu_tk": two ASCII files (accel, gyro; default: the one `*acc*` and one `*gyr*` file in
    `session_dir`, which may be None when both files are given), calibrated without a turntable;
    `gravity` defaults to 9.80665 m/s^2 (the IMU-TK Xsens record was taken at 9.81744).
    """
    from rig.io.calibration_json import write_calibration

    if session_dir is None and fmt == "interchange":
        raise ValueError("an interchange session needs its folder")
    session_dir = Path(session_dir) if session_dir is not None else Path.cwd()
    if fmt == "interchange":
        from rig.io.session_csv import read_session

        session = read_session(session_dir)
        if gravity is not None:
            session.gravity = float(gravity)
        result = calibrate_session(session, method=method, settle_s=settle_s, gyro_samples=gyro_samples)
        g, field_uT = session.gravity, session.field_uT
        source = {"format": "imu-session-csv/1", "path": str(session_dir), "method": method, "settle_s": settle_s,
                  "gyro_samples": gyro_samples}
    elif fmt == "imu_tk":
        g = DEFAULT_GRAVITY if gravity is None else float(gravity)
        result, source = _calibrate_imu_tk(session_dir, accel_file, gyro_file, g)
        field_uT = None
    else:
        raise ValueError(f"fmt must be 'interchange' or 'imu_tk', got {fmt!r}")

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    out_path = out_dir / "calibration.json"
    extra = {"source": source, "warnings": result.warnings,
             "excluded_steps": {str(k): v for k, v in sorted(result.excluded_steps.items())}}
    write_calibration(out_path, result.sensors, gravity=g, field_uT=field_uT, unit_serial=unit_serial,
                      board=board, extra=extra)
    for line in result.summary:
        echo(line)
    for w in result.warnings:
        echo(f"warning: {w}")
    echo(f"wrote {out_path}")
    return result


def summary_lines(result: SessionCalibration) -> list[str]:
    """Per sensor: method, holds, residual, iterations, B and H with their standard deviations."""
    lines = []
    for name, cal in result.sensors.items():
        unit = SENSOR_UNITS.get(name, "?")
        holds = result.holds_used.get(name)
        head = f"{name}: {cal.method}" + (f", {holds} holds" if holds is not None else "")
        residual_unit = "rad per move" if name == "gyro" else unit   # gyro: rotation misfit of each move
        head += f", residual_rms {cal.residual_rms:.3g} {residual_unit}, {cal.iterations} iterations"
        if "sample_model" in cal.extra:
            head += f", samples read as {cal.extra['sample_model']}"
            if len(cal.extra.get("misfit_rad_by_sample_model", ())) == 1:
                head += " (the moves fit within their noise)"
        if not cal.converged:
            head += " (NOT converged)"
        lines.append(head)
        lines.append(f"  B = {_vec(cal.B)} counts" + (f" +/- {_vec(cal.B_std)}" if cal.B_std is not None else ""))
        H_std = np.asarray(cal.H_std) if cal.H_std is not None else None
        for i, row in enumerate(np.asarray(cal.H)):
            label = "  H = " if i == 0 else "      "
            lines.append(label + _vec(row) + (f" +/- {_vec(H_std[i])}" if H_std is not None else "")
                         + (f"  {unit}/count" if i == 0 else ""))
        if "lever_arm_m" in cal.extra:
            verdict = "significant" if cal.extra.get("lever_arm_significant") else "not significant, not applied"
            verdict += f", p = {cal.extra.get('lever_arm_p_value', float('nan')):.2g}"
            lines.append(f"  lever arm r = {_vec(cal.extra['lever_arm_m'])} m +/- {_vec(cal.extra['lever_arm_std_m'])}"
                         f" ({verdict}, {cal.extra.get('lever_arm_rows')} move rows)")
    return lines


def _add_lever_arm(session: SessionData, sensors: dict[str, TriadCalibration], warnings: list[str]) -> None:
    """Locate the accelerometer relative to the table axes from the move rows (rig.calibration.lever_arm),
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
        fit = _solver("lever_arm", "estimate_lever_arm")(session.t, accel, gyro, matrix_from_quat(session.q_ref),
                                                         float(session.gravity), rows)
    except (ValueError, np.linalg.LinAlgError) as e:
        warnings.append(f"accel: no lever arm estimate ({e})")
        return
    sensors["accel"].extra.update({"lever_arm_m": [float(x) for x in fit.r_m],
                                   "lever_arm_std_m": [float(x) for x in fit.std_m],
                                   "lever_arm_significant": bool(fit.significant),
                                   "lever_arm_p_value": float(fit.p_value),
                                   "lever_arm_rows": int(fit.rows_used)})


def _vec(v) -> str:
    return "[" + ", ".join(f"{x: .6g}" for x in np.asarray(v, dtype=float).ravel()) + "]"


def _solver(module: str, name: str):
    """Resolve a solver at call time, so a replaced module (tests, plug-ins) is honoured."""
    return getattr(importlib.import_module(f"rig.calibration.{module}"), name)


def _check_finite(session: SessionData) -> None:
    for label, arr in (("t", session.t), ("reference quaternion", session.q_ref)):
        bad = ~np.isfinite(np.asarray(arr, dtype=float).reshape(len(session.t), -1)).all(axis=1)
        if bad.any():
            raise CalibrationError(f"{session.source}: {label} is NaN/inf on {int(bad.sum())} row(s), first row "
                                   f"{int(np.argmax(bad))}; a session needs them on every row")
    if not (~session.is_move).any():
        raise CalibrationError(f"{session.source}: no 'hold' rows: nothing to calibrate from")


def _warn_partial_nan(session: SessionData, warnings: list[str]) -> None:
    """Rows with NaN in some but not all axes are not 'no sample': they are damaged, and are not used."""
    for name, y in session.raw.items():
        nan = np.isnan(y)
        partial = nan.any(axis=1) & ~nan.all(axis=1)
        if partial.any():
            warnings.append(f"{name}: {int(partial.sum())} row(s) with NaN in some axes only (first row "
                            f"{int(np.argmax(partial))}); not used")


def _warn_empty_holds(session: SessionData, holds: dict[str, HoldStats], settle_s: float, warnings: list[str]) -> None:
    """A hold without samples of a sensor (all NaN, or shorter than the settling time) is named."""
    raw_steps = [j for j, _ in session.hold_rows(0.0)]
    settled = {j for j, _ in session.hold_rows(settle_s)}
    for j in raw_steps:
        if j not in settled:
            warnings.append(f"step {j}: hold shorter than the settling time {settle_s:g} s; not used")
    for name, h in holds.items():
        missing = sorted(settled - set(h.step.tolist()))
        if missing:
            warnings.append(f"{name}: no samples (NaN) in the hold(s) of step {', '.join(map(str, missing))}; not used")


def _find_bad_holds(session: SessionData, holds: dict[str, HoldStats], settle_s: float) -> dict[int, str]:
    """Steps whose holds are untrustworthy for every sensor: motion on the board moves all its chips."""
    bad: dict[int, str] = {}

    def flag(step: int, reason: str) -> None:
        bad[step] = f"{bad[step]}; {reason}" if step in bad else reason

    rows = dict(session.hold_rows(settle_s))
    for name in session.sensors:
        for step, axis, rail in _saturated_holds(session.raw[name], rows):
            flag(step, f"{name} axis {'xyz'[axis]} at its rail {rail:g} counts (saturated)")
        for step, reason in _noisy_holds(holds[name]):
            flag(step, f"{name} {reason}: motion during the hold")
    if "gyro" in holds:
        for step, reason in _turning_holds(holds["gyro"]):
            flag(step, f"gyro {reason}: the table was turning")
    return bad


def _is_rail(v: float) -> bool:
    """Full-scale codes of integer ADCs: 2^k - 1, -2^k, -(2^k - 1) for k >= 7."""
    if not np.isfinite(v) or v != round(v):
        return False
    a = int(abs(v))
    all_ones = ((a + 1) & a) == 0 and a >= 127
    power_of_two = v < 0 and (a & (a - 1)) == 0 and a >= 128
    return all_ones or power_of_two


def _rails(y: np.ndarray) -> list[tuple[int, float]]:
    out = []
    for axis in range(3):
        col = y[:, axis][~np.isnan(y[:, axis])]
        if col.size:
            out += [(axis, float(v)) for v in {col.min(), col.max()} if _is_rail(float(v))]
    return out


def _saturated_holds(y: np.ndarray, rows: dict[int, np.ndarray]) -> list[tuple[int, int, float]]:
    rails = _rails(y)
    return [(step, axis, rail) for step, idx in rows.items() for axis, rail in rails
            if _piles_at(y[idx, axis], rail, min_count=3)]


def _piles_at(values: np.ndarray, rail: float, min_count: int) -> bool:
    """Clipping piles samples up at the rail; an unclipped noisy signal thins out towards its extreme.

    The rail code alone is not enough: a 4096 counts/g accelerometer legitimately reads 4095 at +1 g.
    """
    at = int(np.count_nonzero(values == rail))
    inner = int(np.count_nonzero(values == rail - np.sign(rail)))
    return at >= min_count and at > inner


def _noisy_holds(h: HoldStats) -> list[tuple[int, str]]:
    if len(h.step) < 3:
        return []
    noise = np.linalg.norm(h.std, axis=1)
    median = float(np.median(noise))
    limit = MOTION_STD_FACTOR * median + MOTION_STD_FLOOR_COUNTS
    return [(int(j), f"noise {n:.3g} counts is {n / median if median else np.inf:.3g}x the median hold's {median:.3g}")
            for j, n in zip(h.step, noise) if n > limit]


def _turning_holds(h: HoldStats) -> list[tuple[int, str]]:
    if len(h.step) < 3:
        return []
    centre = np.median(h.mean, axis=0)
    mad = 1.4826 * np.median(np.abs(h.mean - centre), axis=0)
    mean_noise = np.median(h.std / np.sqrt(np.maximum(h.count, 1))[:, None], axis=0)
    sigma = np.maximum(mad, mean_noise)
    sigma = np.where(sigma > 0, sigma, 0.5)  # quantised, noiseless: half a count
    off = np.abs(h.mean - centre)
    z = np.where(off > GYRO_MEAN_FLOOR_COUNTS, off / sigma, 0.0)
    return [(int(j), f"mean {_vec(m)} counts is {zz.max():.3g} robust sigmas from the bias {_vec(centre)}")
            for j, m, zz in zip(h.step, h.mean, z) if zz.max() > GYRO_MEAN_SIGMAS]


def _without_steps(h: HoldStats, excluded: dict[int, str]) -> HoldStats:
    keep = ~np.isin(h.step, list(excluded))
    sel = lambda a: None if a is None else a[keep]  # noqa: E731
    return HoldStats(h.step[keep], h.mean[keep], h.std[keep], h.count[keep], h.R[keep], h.t_start[keep],
                     h.t_end[keep], sel(h.temp_c), sel(h.vsupply_v))


def _calibrate_vector(session: SessionData, name: str, h: HoldStats, method: str,
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
        report = _solver("observability", "check_schedule")(h.R, min_orientations=need)
        if not report.ok:
            raise CalibrationError(f"accel: the hold schedule cannot calibrate: {report.message}")
    _solver("observability", "require_spread")(h.mean, name)
    if method == "joint":
        return _solver("joint", "calibrate_joint")(h.mean, h.R, norm, y_std=h.std, counts=h.count)
    solve = _solver("twostep", "calibrate_two_step")
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


def _calibrate_gyro(session: SessionData, h: HoldStats, excluded: dict[int, str],
                    warnings: list[str], settle_s: float = 0.0, samples: str = "auto") -> TriadCalibration:
    """B from the still holds (eq. 41), H from the moves between trusted holds."""
    if len(h.step) < 1:
        raise CalibrationError("gyro: no usable hold to take the bias from")
    B = np.asarray(_solver("gyro", "gyro_bias")(h.mean, h.count), dtype=float)
    noise = np.maximum(np.median(h.std, axis=0), QUANTISATION_STD)
    moves = _trusted_moves(session, excluded, warnings, settle_s, B, GYRO_STILL_SIGMAS * noise)
    if len(moves) < MIN_GYRO_MOVES:
        raise CalibrationError(f"gyro: {len(moves)} usable moves between holds, need at least {MIN_GYRO_MOVES}")
    _check_move_axes(moves)
    cal = _solver("gyro", "calibrate_gyro")(moves, B, samples=samples, rate_noise_counts=noise)
    _warn_coarse_sampling(moves, cal, warnings)
    if cal.B_std is None and len(h.step) > 1:
        # The holds see the same bias, so its rounding error does not average out over them.
        rounding = rounding_bias_rms(noise_sigma(h.std))
        cal.B_std = np.sqrt(h.mean.var(axis=0, ddof=1) / len(h.step) + rounding ** 2)
    return cal


def _warn_coarse_sampling(moves: list[MoveStream], cal: TriadCalibration, warnings: list[str]) -> None:
    """Where the table's rate profile has a corner between two point samples, no interpolation knows where it
    was: the move's angle is off by up to a/8 dt^2. Measured on the second independent simulator: 5.7 deg per
    sample (200 deg/s on both axes at 50 Hz) leaves a gyro H error of up to 0.022 % with point samples (0.004 %
    with mean samples); 2.8 deg per sample (the same at 100 Hz) 0.005 %."""
    worst = max(float(np.max(np.linalg.norm((m.y - cal.B) @ cal.H.T, axis=1)[1:] * np.diff(m.t))) for m in moves)
    if np.degrees(worst) > COARSE_DEG_PER_SAMPLE:
        warnings.append(f"gyro: the table turns up to {np.degrees(worst):.3g} deg between samples; above "
                        f"{COARSE_DEG_PER_SAMPLE:g} deg the integration between samples limits H to a few 0.01 % "
                        "(sample faster or move slower)")


def _trusted_moves(session: SessionData, excluded: dict[int, str], warnings: list[str], settle_s: float = 0.0,
                   rest: np.ndarray | None = None, still_counts: np.ndarray | None = None) -> list[MoveStream]:
    order = [j for j, _ in session.hold_rows(settle_s)]
    next_step = dict(zip(order[:-1], order[1:]))
    y_all = session.raw["gyro"]
    rails = _rails(y_all)
    out = []
    for m in session.moves("gyro", settle_s):
        end = next_step.get(m.step)
        if m.step in excluded or end in excluded:
            warnings.append(f"gyro: move {m.step} -> {end} not used (touches an excluded hold)")
            continue
        hit = [(axis, rail) for axis, rail in rails if _piles_at(m.y[:, axis], rail, min_count=2)]
        if hit:
            axis, rail = hit[0]
            warnings.append(f"gyro: move {m.step} -> {end} not used: axis {'xyz'[axis]} at its rail {rail:g} "
                            "counts (rate beyond the range)")
            continue
        out.append(m.trimmed_to_motion(rest=rest, still_counts=still_counts))
    return out


def _check_move_axes(moves: list[MoveStream]) -> None:
    """The known rotations must turn the fixture about three independent axes, else H loses a column."""
    from rig.calibration.observability import move_axes_problem

    problem = move_axes_problem(np.array([m.known_rotation for m in moves]))
    if problem:
        raise CalibrationError(f"gyro: {problem}")


def _reference_norm(session: SessionData, name: str) -> float | None:
    return {"accel": session.gravity, "mag": session.field_uT}.get(name)


def _check_result(name: str, cal: TriadCalibration, norm: float | None, warnings: list[str]) -> None:
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


def _calibrate_imu_tk(session_dir: Path, accel_file, gyro_file, gravity: float) -> tuple[SessionCalibration, dict]:
    from rig.io.imu_tk import read_imu_tk

    acc_path = _pick_file(session_dir, accel_file, "*acc*", "accel")
    gyr_path = _pick_file(session_dir, gyro_file, "*gyr*", "gyro")
    t_a, acc = read_imu_tk(acc_path)
    t_g, gyr = read_imu_tk(gyr_path)
    if len(t_a) != len(t_g) or not np.allclose(t_a, t_g, rtol=0, atol=1e-6):
        raise CalibrationError(f"{acc_path} and {gyr_path}: the timestamps differ (rows {len(t_a)} vs {len(t_g)}); "
                               "the turntable-free calibration needs accel and gyro sampled together")
    sensors = _solver("turntable_free", "calibrate_turntable_free")(t_a, acc, gyr, gravity=gravity)
    warnings = ["imu_tk data: no reference orientations; calibrated without a turntable "
                "(static intervals detected from the data)"]
    for name, cal in sensors.items():
        _check_result(name, cal, gravity if name == "accel" else None, warnings)
    result = SessionCalibration(dict(sensors), warnings)
    result.summary = summary_lines(result)
    source = {"format": "imu_tk", "accel_file": str(acc_path), "gyro_file": str(gyr_path), "method": "turntable-free"}
    return result, source


def _pick_file(folder: Path, given, pattern: str, what: str) -> Path:
    if given is not None:
        p = Path(given)
        return p if p.is_absolute() or p.exists() else folder / p
    if not folder.is_dir():
        raise CalibrationError(f"{folder}: not a folder; name the {what} file explicitly")
    found = sorted(p for p in folder.glob(pattern) if p.is_file())
    if len(found) != 1:
        raise CalibrationError(f"{folder}: expected exactly one {what} file matching {pattern!r}, found "
                               f"{[p.name for p in found]}; name it explicitly")
    return found[0]


__all__ = ["SessionCalibration", "calibrate_session", "calibrate_from_dir", "summary_lines"]
