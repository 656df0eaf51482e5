"""Calibrate a whole measured session: what `rig calibrate --from DIR --out OUT` runs.

Screening (`screening.py`) decides what the solvers are fed: it drops the settling time of each hold,
refuses data that cannot give a trustworthy matrix and removes holds that were not still, naming each
step it drops. Solving (`solving.py`) runs the estimators and checks their results; writing
(`writing.py`) is the one writer of calibration.json. The rule throughout: a clear error or a flagged
warning, never a silently wrong matrix.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Callable

from rig.calibration.recordings.recording import calibrate_recording
from rig.calibration.recordings.recording_checks import check_no_stuck_axis
from rig.calibration.turntable.reference_convention import refuse_conjugated_reference
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.numerics.threads import one_blas_thread
from rig.errors import CalibrationError
from rig.io.import_imu_tk import import_imu_tk
from rig.io.session_csv import read_session
from rig.pipeline.move_rows import refine_vector_with_moves
from rig.pipeline.result import SessionCalibration, summary_lines
from rig.pipeline.screening import (check_finite, find_bad_holds, warn_empty_holds, warn_partial_nan,
                                    without_steps)
from rig.pipeline.solving import (METHODS, add_lever_arm, calibrate_gyro_triad, calibrate_vector, check_result,
                                  reference_norm)
from rig.pipeline.writing import write_session_calibration
from rig.session_data import SessionData
from rig.units import STANDARD_GRAVITY


def calibrate_session(session: SessionData, *, method: str = "joint", settle_s: float = 0.5,
                      gyro_samples: str = "auto", move_samples: bool = True) -> SessionCalibration:
    """Calibrate every sensor of `session`; raises CalibrationError where the data cannot support it.

    gyro_samples: what a raw gyro sample means, "point" or "mean" (gyro.calibrate_gyro), or "auto".
    move_samples: the joint accelerometer and magnetometer fits use the samples of the moves too
    (rig.pipeline.move_rows); False keeps them to the hold means.
    """
    with one_blas_thread():
        return _calibrate_session(session, method=method, settle_s=settle_s, gyro_samples=gyro_samples,
                                  move_samples=move_samples)


def _calibrate_session(session: SessionData, *, method: str, settle_s: float, gyro_samples: str,
                       move_samples: bool) -> SessionCalibration:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if session.meta.get("reference") == "none":
        return calibrate_without_table(session)
    check_finite(session)
    # A stuck axis (one value on every row) is refused as in a recording: the turntable fits went on with it, a
    # gyro axis stuck at its bias gave an H 24 times too large with exit 0, a stuck accelerometer or
    # magnetometer axis a refusal that blamed the schedule ("the orientations are coplanar").
    check_no_stuck_axis(session)
    warnings: list[str] = []
    if settle_s > 0:
        warnings.append(f"dropped the first {settle_s:g} s of every hold as settling")
    warn_partial_nan(session, warnings)
    holds = {s: session.holds(s, settle_s) for s in session.sensors}
    warn_empty_holds(session, holds, settle_s, warnings)
    excluded = find_bad_holds(session, holds, settle_s)
    for step, reason in sorted(excluded.items()):
        warnings.append(f"step {step}: excluded, {reason}")
    holds = {s: without_steps(h, excluded) for s, h in holds.items()}
    if "accel" in holds:
        refuse_conjugated_reference(session, holds["accel"])

    sensors: dict[str, TriadCalibration] = {}
    with refused_naming_lost_holds(session, settle_s, excluded):
        for name in session.sensors:
            if name == "gyro":
                sensors[name] = calibrate_gyro_triad(session, holds[name], excluded, warnings, settle_s,
                                                     gyro_samples)
            else:
                sensors[name] = calibrate_vector(session, name, holds[name], method, warnings)
            check_result(name, sensors[name], reference_norm(session, name), warnings)
    add_lever_arm(session, sensors, warnings)
    if move_samples and method == "joint":
        refine_vector_with_moves(session, holds, sensors, excluded, warnings, settle_s)
    result = SessionCalibration(sensors, warnings, excluded_steps=excluded,
                                holds_used={s: len(h.step) for s, h in holds.items()})
    result.summary = summary_lines(result)
    return result


@contextlib.contextmanager
def refused_naming_lost_holds(session: SessionData, settle_s: float, excluded: dict[int, str]):
    """A fit refused for too few holds or moves says which of the recorded ones were not used and why.

    The warnings that name them are printed only with a result, so a session of 0.5 s holds (another tool's
    logger) calibrated with the default 0.5 s settling was refused with "accel: 0 usable orientations, need at
    least 6" about a file with 14 of them, and nothing said that --settle-s had taken them all."""
    try:
        yield
    except CalibrationError as exc:
        recorded = [j for j, _ in session.hold_rows(0.0)]
        settled = {j for j, _ in session.hold_rows(settle_s)}
        short = [j for j in recorded if j not in settled]
        lost = []
        if short:
            lost.append(f"{len(short)} of {len(recorded)} holds are shorter than the settling time {settle_s:g} s "
                        "(--settle-s) and were not used")
        if excluded:
            lost.append(f"{len(excluded)} holds were excluded (step {min(excluded)}: {excluded[min(excluded)]})")
        if not lost:
            raise
        raise CalibrationError(f"{exc}; {'; '.join(lost)}") from None


def calibrate_without_table(session: SessionData) -> SessionCalibration:
    """A recording without a turntable (rig.calibration.recordings.recording): its poses, turns and motions."""
    rec = calibrate_recording(session, g_sensitivity=True)
    warnings = list(rec.warnings)
    for name, cal in rec.sensors.items():
        check_result(name, cal, reference_norm(session, name), warnings)
    result = SessionCalibration(dict(rec.sensors), warnings,
                                holds_used={s: len(rec.poses) for s in rec.sensors if rec.poses},
                                raw_units=dict(session.meta.get("units", {})), refused=dict(rec.refused))
    result.summary = summary_lines(result)
    return result


def calibrate_from_dir(session_dir: str | os.PathLike | None, out_dir: str | os.PathLike, *, fmt: str = "interchange",
                       accel_file: str | os.PathLike | None = None, gyro_file: str | os.PathLike | None = None,
                       method: str = "joint", settle_s: float = 0.5, gravity: float | None = None,
                       gyro_samples: str = "auto",
                       unit_serial: str | None = None, board: str | None = None,
                       echo: Callable[[str], None] = print, move_samples: bool = True,
                       units: dict[str, str] | None = None,
                       initial_rest_s: float | None = None) -> SessionCalibration:
    """Read a session folder, calibrate it, write `OUT/calibration.json`, echo a short summary.

    fmt "interchange": `session_dir` is an `imu-session-csv/1` folder; `gravity` overrides its meta.
    fmt "imu_tk": two ASCII files (accel, gyro; default: the one `*acc*` and one `*gyr*` file in
    `session_dir`, which may be None when both files are given), calibrated without a turntable;
    `gravity` defaults to 9.80665 m/s^2 (the IMU-TK Xsens record was taken at 9.81744); `units` (sensor -> unit,
    counts where not named) and `initial_rest_s` are read as `rig import imu_tk` reads them.
    """
    if session_dir is None and fmt == "interchange":
        raise ValueError("an interchange session needs its folder")
    session_dir = Path(session_dir) if session_dir is not None else Path.cwd()
    session = None
    if fmt == "interchange":
        session = read_session(session_dir)
        if gravity is not None:
            session.gravity = float(gravity)
        result = calibrate_session(session, method=method, settle_s=settle_s, gyro_samples=gyro_samples,
                                   move_samples=move_samples)
        g, field_uT = session.gravity, session.field_uT
        source = {"format": "imu-session-csv/1", "path": str(session_dir), "method": method, "settle_s": settle_s,
                  "gyro_samples": gyro_samples, "move_samples": move_samples}
    elif fmt == "imu_tk":
        g = STANDARD_GRAVITY if gravity is None else float(gravity)
        result, source = _calibrate_imu_tk(session_dir, accel_file, gyro_file, g, units, initial_rest_s)
        field_uT = None
    else:
        raise ValueError(f"fmt must be 'interchange' or 'imu_tk', got {fmt!r}")

    out_path = write_session_calibration(out_dir, result, gravity=g, field_uT=field_uT, unit_serial=unit_serial,
                                         board=board, extra={"source": source}, session=session)
    for line in result.summary:
        echo(line)
    for w in result.warnings:
        echo(f"warning: {w}")
    for sensor, why in result.refused.items():
        echo(f"{sensor}: not calibrated: {why}")
    echo(f"wrote {out_path}")
    return result


def _calibrate_imu_tk(session_dir: Path, accel_file, gyro_file, gravity: float, units: dict[str, str] | None,
                      initial_rest_s: float | None) -> tuple[SessionCalibration, dict]:
    """imu_tk's files read as `rig import imu_tk` reads them and calibrated as that recording is (one way through:
    the same fits, g-sensitivity and refusals as `rig calibrate --from` on the imported session)."""
    acc_path = _pick_file(session_dir, accel_file, "*acc*", "accel")
    gyr_path = _pick_file(session_dir, gyro_file, "*gyr*", "gyro")
    session = import_imu_tk({"accel": acc_path, "gyro": gyr_path}, units=units, gravity=gravity,
                            initial_rest_s=initial_rest_s)
    result = calibrate_without_table(session)
    source = {"format": "imu_tk", "accel_file": str(acc_path), "gyro_file": str(gyr_path), "method": "turntable-free",
              "units": session.meta["imported"]["units"],
              **({"initial_rest_s": initial_rest_s} if initial_rest_s else {})}
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
