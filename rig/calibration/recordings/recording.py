"""Calibrate a recording without a turntable from what its segments say (session-csv.md, "Recordings without a
turntable"): static poses (with the axis that was up, and how far the hand may have tilted it), turns of known
angle about a sensor axis, and the motions between poses; where nothing is said, imu_tk's turntable-free method
with static intervals found in the data (`turntable_free`). Each sensor's fit has its module (`recording_vector`,
`recording_gyro`, `recording_mag`), their math `recording_fits` and `mag_fit`.

Each sensor is calibrated by what the recording holds (docs/reference/recording-kinds.md): the accelerometer from
its still poses, with or without a gyro beside it; the gyro from turns and motions between poses, which need the
accelerometer's gravity; the magnetometer in the accelerometer's frame where one is there (`recording_mag`), else
by itself in its own frame from every sample (`mag_alone`). Every sensor's `frame` says which.

`leave_out` drops poses, turns or motions from the fit, by index in time order, so the same code scores what a
calibration predicts for data it did not see (held-out prediction).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rig.calibration.recordings.carry_weight import CarryWeight
from rig.calibration.recordings.g_sensitivity import with_g_sensitivity
from rig.calibration.recordings.mag_alone import calibrate_mag_alone, directions_text
from rig.calibration.recordings.quasi_static import TOLD_REL, quasi_static_accel, still_intervals, told_relative
from rig.calibration.recordings.recording_checks import (
    check_no_stuck_axis,
    imported_columns,
    refused_for_saturation,
    unclipped_turns_and_motions,
    unsaturated_poses,
)
from rig.calibration.recordings.recording_gyro import fit_gyro, summed_rate, whole_carries
from rig.calibration.recordings.recording_mag import calibrate_recording_mag
from rig.calibration.recordings.recording_vector import vector_fit
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.numerics.saturation import pinned_rows, rail_names
from rig.calibration.recordings.segments import DEFAULT_TILT_SD_DEG, Pose, Turn, segments_of
from rig.calibration.recordings.static_segments import check_static_segments
from rig.calibration.recordings.turntable_free import (
    MIN_INTERVALS,
    TooFewIntervals,
    checked,
    describe_rest,
    turntable_free_accel,
)
from rig.calibration.recordings.turntable_free_gyro import turntable_free_gyro
from rig.errors import CalibrationError
from rig.session_data import SessionData

MIN_AXIS_SD = float(np.radians(0.1))      # a turn's axis from the gyro, at best (rad)


class AccelNotTold(CalibrationError):
    """Neither the still poses nor the quasi-static samples of a record without segments tell its accelerometer:
    it, and every sensor calibrated in its frame, is named not calibrated."""


@dataclass
class RecordingCalibration:
    """Per-sensor calibrations and what the recording contributed to them."""

    sensors: dict[str, TriadCalibration]
    poses: list[Pose]
    turns: list[Turn]
    carries: list[tuple[int, int]]                 # (pose index, next pose index) whose motion carried gravity
    warnings: list[str] = field(default_factory=list)
    refused: dict[str, str] = field(default_factory=dict)   # sensor -> why it could not be calibrated


def calibrate_recording(session: SessionData, *, leave_out: dict | None = None,
                        carry: CarryWeight | None = None, gyro_start: np.ndarray | None = None,
                        g_sensitivity: bool = False, accel: TriadCalibration | None = None) -> RecordingCalibration:
    """Accelerometer (and magnetometer) from the static poses, gyroscope from turns and motions between poses.

    leave_out: {"poses": [i, ...], "turns": [k, ...], "carries": [c, ...]} not used in the fit.
    carry: how far a hand motion's carried gravity is trusted; None: chosen by cross-validation where turns
    say it too (the twin's replicas take the recording's choice rather than choosing again).
    gyro_start: where the gyro's fit starts instead of its own coarse search (a twin's replica starts at its
    recording's H: the same optimum, to 1e-10, in a third less time).
    g_sensitivity: take the gyro's g-sensitivity into its calibration where the poses show it
    (`rig.calibration.recordings.g_sensitivity`; what `rig calibrate` writes). The twin keeps the linear model, and
    names it. accel: the accelerometer's calibration on these very poses, where the caller has it: a held-out refit that
    leaves out only a turn or a motion, which the accelerometer's fit never sees, takes it rather than fitting it
    again (`rig.calibration.recordings.heldout`; the gyro's refit on its g-corrected rate does the same).
    """
    if accel is not None and (leave_out or {}).get("poses"):
        raise ValueError("calibrate_recording: an accelerometer calibration given was fitted on every pose; it cannot "
                         "stand for a refit that leaves out a pose")
    rec = _calibrate_linear(session, leave_out, carry, gyro_start, accel)
    if g_sensitivity and "gyro" in rec.sensors:
        left = set((leave_out or {}).get("poses", ()))
        gyro = with_g_sensitivity(session, rec.sensors, [p.rows for i, p in enumerate(rec.poses) if i not in left],
                                  lambda s: _calibrate_linear(s, leave_out, carry, gyro_start,
                                                              rec.sensors["accel"]).sensors["gyro"])
        if gyro is not None:
            rec.sensors["gyro"] = gyro
    for cal in rec.sensors.values():
        cal.extra.setdefault("frame", "accel")
    return rec


def _calibrate_linear(session: SessionData, leave_out: dict | None, carry: CarryWeight | None,
                      gyro_start: np.ndarray | None, accel: TriadCalibration | None = None) -> RecordingCalibration:
    check_no_stuck_axis(session)
    if "accel" not in session.raw:
        return _without_accelerometer(session)
    poses, turns = segments_of(session)
    if not poses:
        return _turntable_free(session)
    check_static_segments(session, poses, turns)
    poses, saturated = unsaturated_poses(session, poses)
    if not poses:
        raise CalibrationError(f"{session.source}: no static pose is left once {'; '.join(w for _, w in saturated)}")
    leave_out = leave_out or {}
    use_poses = [p for i, p in enumerate(poses) if i not in set(leave_out.get("poses", ()))]
    sensors, warnings = {}, [w for w, _ in saturated]
    with refused_for_saturation(session, [why for _, why in saturated]):
        sensors["accel"] = accel if accel is not None else vector_fit(session, "accel", use_poses, session.gravity)
    carries = whole_carries(session, poses)
    if "gyro" in session.raw:
        turns, carries, clipped = unclipped_turns_and_motions(session, poses, turns, carries)
        warnings += [w for w, _ in clipped]
        with refused_for_saturation(session, [why for _, why in clipped]):
            sensors["gyro"], used = fit_gyro(session, sensors["accel"], poses, turns, carries, leave_out,
                                             carry, gyro_start)
        if not used["turns"] and not used["carries"]:
            warnings.append("gyro: no turn of known angle and no whole motion between poses")
    if "mag" in session.raw:
        left = [p.rows for i, p in enumerate(poses) if i in set(leave_out.get("poses", ()))]
        sensors["mag"], mag_warnings = _mag(session, sensors["accel"], use_poses, _turn_axes(session, sensors, turns),
                                            np.concatenate(left) if left else None)
        warnings += mag_warnings
    return RecordingCalibration(sensors, poses, turns, carries, warnings)


def _turn_axes(session: SessionData, sensors: dict, turns: list[Turn]) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Each turn's rows, its axis in the accelerometer's frame and that axis's standard deviation (rad): the
    calibrated gyro's summed rate, to within the gyro frame's own (a hand's axis is not the nominal one), else
    the nominal axis to within the turn's tilt prior."""
    gyro = sensors.get("gyro")
    if gyro is None or gyro.H_std is None:
        return [(t.rows, np.asarray(t.axis, float), t.axis_sd_rad) for t in turns]
    off = ~np.eye(3, dtype=bool)
    sd = max(float(np.sqrt(np.mean(gyro.H_std[off] ** 2)) / np.abs(np.diag(gyro.H)).mean()), MIN_AXIS_SD)
    return [(t.rows, gyro.H @ summed_rate(session, t.rows, gyro.B), sd) for t in turns]


def _mag(session: SessionData, accel: TriadCalibration, poses: list[Pose], turns: list,
         left_out_rows: np.ndarray | None, quasi_static_rows: np.ndarray | None = None
         ) -> tuple[TriadCalibration, list[str]]:
    """In the accelerometer's frame, to the local field magnitude, or the data's own where the recording has none
    (`field_norm`); its angle to gravity from the accelerometer's quasi-static samples where it was fitted on
    them."""
    norm = float(session.field_uT) if session.field_uT else None
    return calibrate_recording_mag(session, accel, poses, norm, turns, left_out_rows,
                                   raw_unit=session.meta.get("units", {}).get("mag", "counts"),
                                   quasi_static_rows=quasi_static_rows)


def _without_accelerometer(session: SessionData, accel_refused: str | None = None) -> RecordingCalibration:
    """No accelerometer, or one the recording cannot calibrate (`accel_refused` says why): a magnetometer by itself,
    every sample (still or not), in its own frame; a gyro beside it is `refused` (its motions are tied to
    gravity), as is a magnetometer that cannot be calibrated where the accelerometer was refused."""
    if "mag" not in session.raw and accel_refused is None:
        raise CalibrationError(f"{session.source}: a recording is calibrated from its accelerometer or its "
                               f"magnetometer, and this one has neither ({', '.join(session.raw)})")
    refused = {"accel": accel_refused} if accel_refused else {}
    if "gyro" in session.raw:
        refused["gyro"] = (f"{session.source}: a gyroscope is calibrated by the gravity its motions carry between "
                           "still poses, and the recording has "
                           + ("no accelerometer" if accel_refused is None else "no calibrated accelerometer"))
    if "mag" not in session.raw:
        return RecordingCalibration({}, [], [], [], [], refused)
    found, pinned = pinned_rows(np.nan_to_num(session.raw["mag"]))
    y = session.raw["mag"][~pinned]
    warnings = [f"mag: {rail_names('mag', found, imported_columns(session, 'mag'))}: those samples left out "
                "(saturated: the field beyond the range)"] if found else []
    try:
        mag, mag_warnings = calibrate_mag_alone(y, session.field_uT, source=str(session.source),
                                                raw_unit=session.meta.get("units", {}).get("mag", "counts"))
    except CalibrationError as exc:
        if accel_refused is None:
            raise
        refused["mag"] = str(exc)
        return RecordingCalibration({}, [], [], [], warnings, refused)
    return RecordingCalibration({"mag": mag}, [], [], [], warnings + mag_warnings, refused)


def _accel_without_segments(t: np.ndarray, accel: np.ndarray, gravity: float, rest: float | None,
                            columns: list[str] | None, gyro: np.ndarray | None
                            ) -> tuple[TriadCalibration, np.ndarray | None]:
    """imu_tk's fit where the record holds MIN_INTERVALS still poses that tell it to TOLD_REL, else the norm of its
    quasi-static samples (`quasi_static`), with the rows it was fitted on (None for imu_tk's). A record posed too
    few times (most of the static intervals it holds are still, but fewer than MIN_INTERVALS) keeps imu_tk's
    refusal, which asks for more poses: it was meant to be posed. The static intervals
    imu_tk found stay in the quasi-static fit's extra: a gyro beside it is still fitted across them. Where neither
    tells it to TOLD_REL, AccelNotTold (the caller names every sensor not calibrated)."""
    try:
        poses = turntable_free_accel(t, accel, gravity=gravity, init_static_s=rest, columns=columns,
                                     pose_means=True, gyro_raw=gyro)
    except TooFewIntervals as exc:
        poses, refused = None, exc
        if 2 * len(still_intervals(t, accel, exc.intervals)) > len(exc.intervals):
            raise                                   # posed, but too few times: imu_tk's refusal asks for more
    still = still_intervals(t, accel, poses.extra["intervals"]) if poses is not None else []
    if len(still) >= MIN_INTERVALS and told_relative(poses, gravity) <= TOLD_REL:
        return poses, None
    try:
        fit = quasi_static_accel(t, accel, gravity, still=len(still))
    except CalibrationError as exc:
        if poses is None:
            raise CalibrationError(f"{refused}; nor can it be fitted without still poses: {exc}") from None
        told = told_relative(poses, gravity)
        intervals = poses.extra["intervals"]
        why = (f"{len(still)} of its {len(intervals)} static intervals are still, and its quasi-static samples do "
               f"not tell it either: {exc}")
        if told > TOLD_REL:
            means = np.array([accel[a:b + 1].mean(axis=0) for a, b in intervals])
            where = directions_text(means / np.linalg.norm(means, axis=1, keepdims=True), "accelerometer")
            raise AccelNotTold(f"accel: its static intervals leave it undetermined, known to only {100 * told:.2g} % "
                               f"(at most {100 * TOLD_REL:g} %): {where}; {why}") from None
        if len(still) < MIN_INTERVALS:
            poses.warnings.append(why)
        return poses, None
    if poses is not None:
        fit.calibration.extra.update({k: poses.extra[k] for k in ("intervals", "initial_rest_s", "initial_rest")
                                      if k in poses.extra})
    return fit.calibration, fit.rows


def _turntable_free(session: SessionData) -> RecordingCalibration:
    """No segments: imu_tk's method, static intervals detected in the data (the initial rest too, unless the
    recording says it: meta `initial_rest_s`). A gyro that cannot be calibrated from them (poses not held still,
    motions too coarse or clipped) is `refused`; the accelerometer (and magnetometer) still are. Without a gyro, the
    accelerometer's poses are found all the same."""
    accel = session.raw["accel"]
    gyro = session.raw.get("gyro")
    rows = ~np.isnan(accel).any(axis=1)
    if gyro is not None:
        rows &= ~np.isnan(gyro).any(axis=1)
        gyro = gyro[rows]
    t, accel = session.t[rows], accel[rows]
    rest = session.meta.get("initial_rest_s")           # None: found in the data
    columns = {s: imported_columns(session, s) for s in ("accel", "gyro")}
    sensors, refused = {}, {}
    try:                                                # name the recording, as every other refusal here does
        sensors["accel"], quasi_rows = _accel_without_segments(t, accel, session.gravity, rest, columns["accel"],
                                                               gyro)
        if gyro is not None and "intervals" not in sensors["accel"].extra:
            refused["gyro"] = (f"{session.source}: gyro: it is calibrated by the gravity its motions carry between "
                               "still poses, and the record holds none (its accelerometer was fitted to its "
                               "quasi-static samples)")
        elif gyro is not None:
            try:
                sensors["gyro"] = turntable_free_gyro(t, accel, checked(t, gyro, "gyro"), sensors["accel"],
                                                      columns=columns["gyro"])
            except CalibrationError as exc:
                refused["gyro"] = f"{session.source}: {exc}"
    except AccelNotTold as exc:
        return _without_accelerometer(session, f"{session.source}: {exc}")
    except (CalibrationError, ValueError) as exc:
        raise CalibrationError(f"{session.source}: {exc}") from None
    intervals = (sensors.get("gyro") or sensors["accel"]).extra.get("intervals", [])
    index = np.flatnonzero(rows)
    poses = [Pose(f"static {k}", index[a:b + 1], None, DEFAULT_TILT_SD_DEG) for k, (a, b) in enumerate(intervals)]
    warnings = ["no segments: " + ("static intervals detected in the data (imu_tk's turntable-free method; "
                                   f"{describe_rest(sensors['accel'].extra)})" if quasi_rows is None else
                                   "the accelerometer fitted to the norm of its quasi-static samples")]
    if "mag" in session.raw:
        try:
            sensors["mag"], mag_warnings = _mag(session, sensors["accel"], poses, [], None,
                                                None if quasi_rows is None else index[quasi_rows])
            warnings += mag_warnings
        except CalibrationError as exc:                 # the other sensors are calibrated all the same
            refused["mag"] = str(exc) if str(session.source) in str(exc) else f"{session.source}: {exc}"
    carries = [(i, i + 1) for i in sensors["gyro"].extra["whole_motions"]] if "gyro" in sensors else []
    return RecordingCalibration(sensors, poses, [], carries, warnings, refused)
