"""A recording's magnetometer, calibrated from what any hand or bench session has: every sample reads the same
field magnitude, and every still pose the same angle between field and gravity (`mag_fit`).

Before, a recording's magnetometer was fitted to the norm of its still poses alone, which needs nine and gives an
H in a frame of its own: a six-face session was refused for not saying which axis was up (it never can, for a
field), and a session without segments dropped its magnetometer without a word. What cannot be calibrated is
said in one line naming the recording and the columns: a field that is not the same in every pose (iron nearby)
is named and left out. A mirrored axis cannot be told from a field that points the other way: one column of the
opposite sign, with the field reversed (`-F`, a half turn), is a proper rotation, so the fit reads the field
reversed, its angles to gravity and its carried directions as right as the true one's, and only the sign of the
dip tells them apart. That sign is the user's hemisphere, which the recording does not know: a field pointing up
is said in a warning, not refused.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.numerics.field_norm import data_field_norm, to_data_field
from rig.calibration.recordings.mag_alone import field_from_data_warning
from rig.calibration.numerics.mag_fit import best_rotation, joint_fit, sphere_start
from rig.calibration.recordings.quasi_static_mag import dip_sd_from_accel, quasi_static_mag
from rig.calibration.recordings.recording_checks import imported_columns
from rig.calibration.recordings.recording_vector import gravity_directions
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.numerics.saturation import pinned_rows, rail_names
from rig.calibration.recordings.segments import Pose
from rig.calibration.numerics.uncertainty import inherited_frame_cov
from rig.errors import CalibrationError
from rig.session_data import SessionData, filled

MAX_SAMPLES = 20_000          # every k-th sample beyond this: the sphere is as well covered, the fit faster
MIN_POSES = 4                 # the rotation (3) and the dip (1) from the poses' angles to gravity
DISTURBED = 0.03              # a pose whose field is this far off the others' magnitude is not the Earth's alone
TURN_SAMPLES = 400            # of a turn's samples, evenly spread: its axis is as well fixed
MIN_TURN_SAMPLES = 20
RAIL_SIGMAS = 3.0
RAIL_WINDOW = 9


def calibrate_recording_mag(session: SessionData, accel: TriadCalibration, poses: list[Pose], norm: float | None,
                            turns: list[tuple[np.ndarray, np.ndarray, float]] = (),
                            left_out_rows: np.ndarray | None = None,
                            raw_unit: str = "counts", quasi_static_rows: np.ndarray | None = None
                            ) -> tuple[TriadCalibration, list[str]]:
    """The magnetometer's calibration in the accelerometer's frame, and warnings (poses left out). `turns`: (rows,
    axis in the accelerometer's frame, its standard deviation in rad) of turns about a fixed axis, along which the field
    stays the same: a six-face session's faces, put down with the box against one edge, leave the rotation about an axis
    open that its turns fix (7 deg off, stated as 1, before they were used). `norm` None: the recording does not say the
    local field magnitude, and the one its samples show is taken (`field_norm`; `raw_unit` the samples' unit).
    The dip (the field's angle below the horizon, the same in every still pose: the dot-product invariant that
    Kok and Schon, "Magnetometer calibration using inertial sensors", IEEE Sensors J. 16(14), 2016, use in their
    joint model of the magnetometer and the inertial sensors) comes with its standard deviation.
    `quasi_static_rows`: where the accelerometer was fitted to its quasi-static samples (`quasi_static`), those
    rows' angles to gravity fix the rotation instead of the poses' means (`quasi_static_group`)."""
    y_all = session.raw["mag"]
    usable = ~np.isnan(y_all).any(axis=1)
    warnings = []
    found, pinned = pinned_rows(np.where(usable[:, None], y_all, 0.0))
    usable &= ~pinned
    if found:
        usable &= ~near_rails(y_all, found, poses)
        warnings.append(f"mag: {rail_names('mag', found, imported_columns(session, 'mag'))}: those samples and the "
                        f"ones within {RAIL_SIGMAS:g} noise deviations of the rail left out (a clipped pose's samples "
                        "inside the range are the tail of its noise)")
    if left_out_rows is not None:
        usable[left_out_rows] = False
    poses = [p for p in poses if usable[p.rows].sum() >= 2]
    if quasi_static_rows is not None:
        return quasi_static_mag(session, accel, norm, quasi_static_rows[usable[quasi_static_rows]], usable, raw_unit,
                                warnings)
    if len(poses) < MIN_POSES:
        raise CalibrationError(f"{session.source}: mag: {len(poses)} still poses with magnetometer samples; its "
                               f"alignment with the accelerometer needs at least {MIN_POSES}")
    y = y_all[usable][::max(1, int(usable.sum()) // MAX_SAMPLES)]
    from_data = norm is None
    if from_data:
        norm = data_field_norm(sphere_start(y, 1.0)[1])
    B, S = sphere_start(y, norm)
    kept, named = _undisturbed(session, poses, usable, B, S, norm)
    if named:
        warnings.append(f"mag: {named}: left out (the field there is not the one the other poses read: iron "
                        "nearby, a steel bench or a magnet?)")
        for k, p in enumerate(poses):              # and the motions to and from it: the iron was near them too
            if p not in kept:
                usable[poses[k - 1].rows[-1] + 1 if k else 0:poses[k + 1].rows[0] if k + 1 < len(poses) else None] = False
        y = y_all[usable][::max(1, int(usable.sum()) // MAX_SAMPLES)]
        B, S = sphere_start(y, norm)
        poses = kept
    means = np.array([y_all[p.rows][usable[p.rows]].mean(axis=0) for p in poses])
    g = gravity_directions(session, accel, poses)
    turns = [(rows[usable[rows]], axis, sd) for rows, axis, sd in turns if usable[rows].sum() >= MIN_TURN_SAMPLES]
    groups = [(means, g)] + [_turn_group(y_all, rows, axis) for rows, axis, _ in turns]
    Q, _ = best_rotation(S, B, groups, norm)
    B, H, cov, info = joint_fit(y, groups, norm, B, Q @ S, [sd for *_, sd in turns])
    field = {"field_uT_source": "given"}
    if from_data:
        scaled = to_data_field(H, norm, cov[3:, 3:], cov[:3, 3:])
        info["norm_rms"] *= scaled.field / norm                 # a share of the field, in its new magnitude
        H, cov[3:, 3:], cov[:3, 3:], norm = scaled.H, scaled.H_cov, scaled.B_H_cov, scaled.field
        cov[3:, :3] = cov[:3, 3:].T
        field = {"field_uT_source": "data", "field_magnitude": norm, "field_magnitude_std": scaled.field_std,
                 "field_magnitude_unit": raw_unit, **({"unit": raw_unit} if raw_unit != "uT" else {})}
        warnings.append(field_from_data_warning(norm, scaled.field_std, raw_unit))
    if info["dip_deg"] < 0:
        warnings.append(f"mag: the field points {-info['dip_deg']:.0f} deg up from the horizon: right in the southern "
                        "magnetic hemisphere; in the northern one a magnetometer column has the opposite sign (a "
                        "mirrored axis, read here as the field reversed)")
    inherited = inherited_frame_cov(accel, H)            # the poses' gravity is in the accelerometer's frame
    if inherited is not None:
        cov[3:, 3:] += inherited
    pose_err = np.linalg.norm((means - B) @ H.T, axis=1) / norm - 1.0
    return TriadCalibration(
        B=B, H=H, method="recording-field (every sample's field magnitude, each still pose's angle to gravity)",
        residual_rms=info["norm_rms"], iterations=info["iterations"], converged=info["converged"],
        B_std=np.sqrt(np.clip(np.diag(cov)[:3], 0, None)), H_std=np.sqrt(np.clip(np.diag(cov)[3:], 0, None)).reshape(3, 3),
        B_cov=cov[:3, :3], H_cov=cov[3:, 3:],
        extra={"poses": [p.name for p in poses], "samples": int(len(y)), "dip_deg": info["dip_deg"],
               "dip_std_deg": _dip_std_deg(info["dip_std_deg"], session, accel, poses, means, B, H),
               "dip_rms_deg": float(np.degrees(info["dot_rms"])),
               "pose_norm_error": pose_err.tolist(), **field}), warnings


def _dip_std_deg(fit_sd_deg: float, session: SessionData, accel: TriadCalibration, poses: list[Pose],
                 means: np.ndarray, B: np.ndarray, H: np.ndarray) -> float:
    """The dip's standard deviation: the fit's, which takes the accelerometer's gravity directions as exact, and
    what the accelerometer's own B and H deviations make of it (their error is shared by every pose, so the
    poses' scatter does not show it): the mean angle's derivatives in them by central differences, through B_cov
    and H_cov."""
    if accel.B_cov is None or accel.H_cov is None:
        return fit_sd_deg
    a = np.array([np.nanmean(session.raw["accel"][p.rows], axis=0) for p in poses])
    return float(np.hypot(fit_sd_deg, dip_sd_from_accel(accel, a, means, B, H)))


def near_rails(y: np.ndarray, found: list, poses: list[Pose]) -> np.ndarray:
    """Rows whose field, its noise averaged out over RAIL_WINDOW samples, lies within RAIL_SIGMAS of the still
    poses' noise of a rail, and the whole of any pose that has one: where the field is near the range's end, the
    samples that noise carries beyond it read the rail, those it leaves inside are the lower tail alone, and
    their mean is off (leaving out only the rail's own samples kept B 5.8 of its deviations off)."""
    sd = np.nanmedian([np.nanstd(y[p.rows], axis=0, ddof=1) for p in poses], axis=0)
    kernel = np.ones(RAIL_WINDOW) / RAIL_WINDOW
    smooth = np.stack([np.convolve(column, kernel, mode="same") for column in filled(y).T], axis=1)
    near = np.zeros(len(y), dtype=bool)
    for r in found:
        near |= np.abs(smooth[:, r.axis] - r.value) < RAIL_SIGMAS * sd[r.axis]
    for p in poses:
        near[p.rows] |= near[p.rows].any()
    return near


def _turn_group(y_all: np.ndarray, rows: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rows = rows[::max(1, len(rows) // TURN_SAMPLES)]
    return y_all[rows], np.tile(axis / np.linalg.norm(axis), (len(rows), 1))


def _undisturbed(session: SessionData, poses: list[Pose], usable: np.ndarray, B: np.ndarray, S: np.ndarray,
                 norm: float) -> tuple[list[Pose], str]:
    """The poses whose field magnitude is the others', and a description of those that are not."""
    err = np.array([np.median(np.linalg.norm((session.raw["mag"][p.rows][usable[p.rows]] - B) @ S.T, axis=1))
                    for p in poses]) / norm
    err = err / np.median(err) - 1.0
    off = np.abs(err) > DISTURBED
    if not off.any() or len(poses) - off.sum() < MIN_POSES:
        return poses, ""
    named = ", ".join(f"pose {p.name} reads {100 * e:+.1f} %" for p, e, o in zip(poses, err, off) if o)
    return [p for p, o in zip(poses, off) if not o], f"{int(off.sum())} of {len(poses)} poses ({named})"
