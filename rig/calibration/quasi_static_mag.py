"""A recording's magnetometer beside an accelerometer fitted to its quasi-static samples (`quasi_static`).

Such a record holds too few still poses for `recording_mag`'s angles to gravity, but every quasi-static sample
holds the angle between field and gravity as well as a pose does, to within what the hand's acceleration turns
gravity's direction by: the rotation from the magnetometer onto the accelerometer's frame and the dip are fitted
by `mag_fit.joint_fit` with those samples as the one group of directions. The hand's acceleration lasts for a
gesture, so neighbouring samples' cosines are one piece of evidence: the covariance is the cluster-robust sandwich
over BLOCKS blocks of consecutive samples (Liang and Zeger, Biometrika 73, 1986; the accelerometer's own fit,
`quasi_static.block_covariance`, does the same), widened by Student's t on G - 1 degrees of freedom.
"""

from __future__ import annotations

import numpy as np
from scipy.special import stdtrit

from rig.calibration.field_norm import data_field_norm, to_data_field
from rig.calibration.mag_alone import MAX_MAGNITUDE_RMS, MAX_RELATIVE_SD, field_from_data_warning
from rig.calibration.mag_fit import best_rotation, joint_fit, sphere_start
from rig.calibration.mag_model import jacobian, residuals
from rig.calibration.quasi_static import BLOCKS, OUTSIDE_ONE_SIGMA
from rig.calibration.result import TriadCalibration
from rig.calibration.uncertainty import inherited_frame_cov
from rig.errors import CalibrationError
from rig.session_data import SessionData

MAX_SAMPLES = 20_000          # every k-th sample beyond this: the sphere is as well covered, the fit faster
MAX_GROUP = 5_000             # of the quasi-static samples, evenly spread: the angle is as well fixed
MIN_SAMPLES = 200


def quasi_static_mag(session: SessionData, accel: TriadCalibration, norm: float | None, rows: np.ndarray,
                     usable: np.ndarray, raw_unit: str, warnings: list[str]) -> tuple[TriadCalibration, list[str]]:
    """The magnetometer in the frame of `accel` (fitted on the quasi-static `rows`), every `usable` sample's field
    magnitude `norm` (None: the data's own) and the rows' angle to gravity; CalibrationError where too few."""
    if len(rows) < MIN_SAMPLES:
        raise CalibrationError(f"{session.source}: mag: {len(rows)} quasi-static samples with magnetometer samples; "
                               f"its alignment with the accelerometer needs at least {MIN_SAMPLES}")
    y_all = session.raw["mag"]
    index = np.flatnonzero(usable)[::max(1, int(usable.sum()) // MAX_SAMPLES)]
    y = y_all[index]
    rows = rows[::max(1, len(rows) // MAX_GROUP)]
    g = accel.apply(session.raw["accel"][rows])
    group = (y_all[rows], g / np.linalg.norm(g, axis=1, keepdims=True))
    from_data = norm is None
    if from_data:
        norm = data_field_norm(sphere_start(y, 1.0)[1])
    B, S = sphere_start(y, norm)
    Q, _ = best_rotation(S, B, [group], norm)
    B, H, _, info = joint_fit(y, [group], norm, B, Q @ S)
    if info["norm_rms"] > MAX_MAGNITUDE_RMS * norm:
        raise CalibrationError(f"{session.source}: mag: the samples do not lie on one ellipsoid: their magnitudes "
                               f"scatter {100 * info['norm_rms'] / norm:.3g} % of the field about it (at most "
                               f"{100 * MAX_MAGNITUDE_RMS:g} %): a field disturbed by iron nearby, or a magnet")
    p = np.r_[B, H.ravel() / norm, -np.sin(np.radians(info["dip_deg"]))]
    cov, factor, blocks = _block_covariance(p, y, index, group, rows, info["norm_rms"] / norm, info["dot_rms"])
    cov = cov * np.r_[np.ones(3), np.full(9, norm), 1.0][:, None] * np.r_[np.ones(3), np.full(9, norm), 1.0][None]
    dip_sd = float(np.degrees(np.sqrt(max(cov[12, 12], 0.0)) / max(np.cos(np.radians(info["dip_deg"])), 1e-12)))
    cov = cov[:12, :12]
    _refuse_untold(session, B, H, cov, norm, info)
    dip_sd = float(np.hypot(dip_sd, _dip_sd_from_accel(accel, session.raw["accel"][rows], group[0], B, H)))
    field = {"field_uT_source": "given"}
    if from_data:
        scaled = to_data_field(H, norm, cov[3:, 3:], cov[:3, 3:])
        info["norm_rms"] *= scaled.field / norm
        H, cov[3:, 3:], cov[:3, 3:], norm = scaled.H, scaled.H_cov, scaled.B_H_cov, scaled.field
        cov[3:, :3] = cov[:3, 3:].T
        field = {"field_uT_source": "data", "field_magnitude": norm, "field_magnitude_std": scaled.field_std,
                 "field_magnitude_unit": raw_unit, **({"unit": raw_unit} if raw_unit != "uT" else {})}
        warnings.append(field_from_data_warning(norm, scaled.field_std, raw_unit))
    inherited = inherited_frame_cov(accel, H)
    if inherited is not None:
        cov[3:, 3:] += inherited
    warnings.append(f"mag: aligned with the accelerometer by the angle to gravity of {len(rows)} quasi-static "
                    f"samples (no still poses); B_std and H_std from {blocks} blocks of consecutive samples, "
                    f"{np.sqrt(factor):.2g} times what independent samples would state")
    return TriadCalibration(
        B=B, H=H, method="recording-field (every sample's field magnitude, the quasi-static samples' angle to "
                         "gravity)",
        residual_rms=info["norm_rms"], iterations=info["iterations"], converged=info["converged"],
        B_std=np.sqrt(np.clip(np.diag(cov)[:3], 0, None)),
        H_std=np.sqrt(np.clip(np.diag(cov)[3:], 0, None)).reshape(3, 3), B_cov=cov[:3, :3], H_cov=cov[3:, 3:],
        extra={"poses": [], "samples": int(len(y)), "quasi_static_samples": int(len(rows)),
               "dip_deg": info["dip_deg"], "dip_std_deg": dip_sd, "dip_rms_deg": float(np.degrees(info["dot_rms"])),
               "residual_correlation_factor": factor, **field}), warnings


def _refuse_untold(session: SessionData, B: np.ndarray, H: np.ndarray, cov: np.ndarray, norm: float,
                   info: dict) -> None:
    """CalibrationError where an entry of B (as field) or H is known worse than mag_alone's MAX_RELATIVE_SD of the
    field: a field whose magnitude changes with time (iron or a magnet carried along) bends the fit's ellipsoid
    until its deviations, once the residuals' dependence is counted, say it is no one ellipsoid."""
    scale = float(np.abs(np.diag(H)).mean())
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    relative = np.r_[sd[:3] * scale / norm, sd[3:] / scale]
    worst = int(np.argmax(relative))
    if relative[worst] > MAX_RELATIVE_SD:
        name = f"B[{worst}]" if worst < 3 else f"H[{(worst - 3) // 3}, {(worst - 3) % 3}]"
        raise CalibrationError(f"{session.source}: mag: its samples tell no one ellipsoid: {name} is known to only "
                               f"{100 * relative[worst]:.2g} % of the field (at most {100 * MAX_RELATIVE_SD:g} %; "
                               f"the magnitudes scatter {100 * info['norm_rms'] / norm:.2g} % about it, the angles to "
                               f"gravity {np.degrees(info['dot_rms']):.2g} deg): a field disturbed by iron nearby or "
                               "a magnet carried along, or too few directions")


def _dip_sd_from_accel(accel: TriadCalibration, a: np.ndarray, m: np.ndarray, B: np.ndarray, H: np.ndarray
                       ) -> float:
    """What the accelerometer's own B and H deviations make of the dip (deg): they are shared by every sample, so
    the samples' scatter does not show them; the mean angle's derivatives by central differences, through B_cov
    and H_cov (as `recording_mag` does for still poses)."""
    if accel.B_cov is None or accel.H_cov is None:
        return 0.0
    f = (m - B) @ H.T
    f /= np.linalg.norm(f, axis=1, keepdims=True)

    def mean_angle(x: np.ndarray) -> float:
        g = (a - x[:3]) @ x[3:].reshape(3, 3).T
        return float(np.mean(np.arcsin(np.clip(np.sum(g * f, axis=1) / np.linalg.norm(g, axis=1), -1.0, 1.0))))

    x0 = np.concatenate([accel.B, np.asarray(accel.H, float).ravel()])
    steps = np.r_[np.full(3, 1e-6 * float(np.abs(a - accel.B).max())), np.full(9, 1e-6 * float(np.abs(accel.H).max()))]
    grad = np.array([(mean_angle(x0 + h * e) - mean_angle(x0 - h * e)) / (2 * h) for h, e in zip(steps, np.eye(12))])
    var = grad[:3] @ accel.B_cov @ grad[:3] + grad[3:] @ accel.H_cov @ grad[3:]
    return float(np.degrees(np.sqrt(max(var, 0.0))))


def _block_covariance(p: np.ndarray, y: np.ndarray, y_rows: np.ndarray, group: tuple[np.ndarray, np.ndarray],
                      group_rows: np.ndarray, norm_sd: float, dot_sd: float) -> tuple[np.ndarray, float, int]:
    """The covariance of p = (B, vec H / M, c) clustered over BLOCKS time blocks of the record (the magnitudes'
    rows and the cosines' rows of one stretch of time are one cluster), the ratio of its diagonal to that of
    independent residuals (averaged) and the blocks used."""
    w = np.r_[np.full(len(y), 1.0 / max(norm_sd, 1e-12)), np.full(len(group[0]), 1.0 / max(dot_sd, 1e-12))]
    J = jacobian(p, y, [group]) * w[:, None]
    r = residuals(p, y, [group]) * w
    when = np.r_[y_rows, group_rows]
    start, span = int(when.min()), int(when.max() - when.min()) + 1
    label = ((when - start) * BLOCKS) // span
    present = np.unique(label)
    G = len(present)
    A_inv = np.linalg.pinv(J.T @ J)
    scores = np.array([J[label == b].T @ r[label == b] for b in present])
    student = float(stdtrit(G - 1, 1.0 - OUTSIDE_ONE_SIGMA / 2)) ** 2 if G > 1 else np.inf
    clustered = A_inv @ (scores.T @ scores) @ A_inv * G / max(G - 1, 1) * student
    plain = A_inv * float(r @ r) / max(len(r) - len(p), 1)
    factor = float(np.mean(np.diag(clustered) / np.where(np.diag(plain) > 0, np.diag(plain), np.inf)))
    return (clustered if factor >= 1 else plain), max(factor, 1.0), G
