"""A recording's magnetometer beside an accelerometer fitted to its quasi-static samples (`quasi_static`).

Such a record holds too few still poses for `recording_mag`'s angles to gravity, but every quasi-static sample
holds the angle between field and gravity as well as a pose does, to within what the hand's acceleration turns
gravity's direction by. Two steps, each on the evidence that is its own:

1. B and the symmetric S onto the unit sphere from every sample's magnitude (`mag_alone.fit_sphere`, its
   covariance widened for the residuals' dependence): the magnitude does not see the hand's acceleration.
2. The rotation Q onto the accelerometer's frame and the cosine c of the field's angle to gravity from the
   quasi-static samples, `(Q S (m - B) / |.|) . g = c` (the dot-product invariant of Kok and Schon, "Magnetometer
   calibration using inertial sensors", IEEE Sensors J. 16(14), 2016), started at `mag_fit.best_rotation`. The
   hand's acceleration biases gravity's direction for as long as a gesture, so neighbouring samples' cosines are
   one piece of evidence: the covariance of (Q, c) is the cluster-robust sandwich over BLOCKS blocks of
   consecutive samples (Liang and Zeger, Biometrika 73, 1986; the accelerometer's fit does the same), widened by
   Student's t on G - 1 degrees of freedom. Fitted together (`mag_fit.joint_fit`), the cosines' shared bias
   pulled B up to 4 of its stated deviations off on synthetic slow sweeps.

H = M Q S; its covariance that of S turned by Q, plus `[dtheta]x H` of the rotation's, plus the accelerometer
frame's own (`uncertainty.inherited_frame_cov`). Refused where an entry is told worse than mag_alone's
MAX_RELATIVE_SD of the field (a field whose magnitude changes with time).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation
from scipy.special import stdtrit

from rig.calibration.numerics.field_norm import data_field_norm, to_data_field
from rig.calibration.recordings.mag_alone import DUPLICATION, MAX_RELATIVE_SD, field_from_data_warning, fit_sphere
from rig.calibration.numerics.mag_fit import best_rotation
from rig.calibration.recordings.quasi_static import BLOCKS, OUTSIDE_ONE_SIGMA
from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.numerics.uncertainty import inherited_frame_cov
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
    fit = fit_sphere(y, what=f"{session.source}: mag")
    from_data = norm is None
    if from_data:
        norm = data_field_norm(fit.S)
    Q, _ = best_rotation(fit.S, fit.B, [group], 1.0)
    x, c, xc_cov, factor, blocks, dot_rms = _rotation_fit(Q, fit.S, fit.B, group, rows)
    Q = Rotation.from_rotvec(x).as_matrix() @ Q
    B, H = fit.B, norm * Q @ fit.S
    D = np.zeros((12, 9))
    D[:3, :3] = np.eye(3)
    D[3:, 3:] = DUPLICATION
    to_H = np.zeros((12, 12))                       # (B, vec S) -> (B, vec H), H = M Q S
    to_H[:3, :3] = np.eye(3)
    to_H[3:, 3:] = norm * np.kron(Q, np.eye(3))
    cov = to_H @ D @ fit.cov @ D.T @ to_H.T
    turn = np.column_stack([(_skew(e) @ H).ravel() for e in np.eye(3)])
    cov[3:, 3:] += turn @ xc_cov[:3, :3] @ turn.T   # dH = [dtheta]x H
    sine = float(np.clip(-c, -1.0, 1.0))
    info = {"norm_rms": fit.residual_rms * norm, "dip_deg": float(np.degrees(np.arcsin(sine))), "dot_rms": dot_rms,
            "iterations": fit.iterations, "converged": fit.converged}
    dip_sd = float(np.degrees(np.sqrt(max(xc_cov[3, 3], 0.0)) / max(np.sqrt(1.0 - sine * sine), 1e-12)))
    _refuse_untold(session, B, H, cov, norm, info)
    dip_sd = float(np.hypot(dip_sd, dip_sd_from_accel(accel, session.raw["accel"][rows], group[0], B, H)))
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


def dip_sd_from_accel(accel: TriadCalibration, a: np.ndarray, m: np.ndarray, B: np.ndarray, H: np.ndarray
                       ) -> float:
    """What the accelerometer's own B and H deviations make of the dip (deg): they are shared by every sample, so
    the samples' scatter does not show them (nor the poses' scatter, where `a` and `m` are pose means); the mean
    angle's derivatives by central differences, through B_cov and H_cov."""
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


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotation_fit(Q: np.ndarray, S: np.ndarray, B: np.ndarray, group: tuple[np.ndarray, np.ndarray],
                  rows: np.ndarray) -> tuple[np.ndarray, float, np.ndarray, float, int, float]:
    """The small rotation x (rotation vector, applied after Q) and the cosine c for which every quasi-static
    sample's field `x Q S (m - B)` makes the angle arccos(c) with its gravity direction; their covariance (4, 4)
    clustered over BLOCKS time blocks (see the module), its ratio to that of independent residuals, the blocks,
    and the cosines' RMS scatter (rad)."""
    v = (group[0] - B) @ S.T @ Q.T
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    d = group[1]

    def fun(p: np.ndarray) -> np.ndarray:
        return np.sum((v @ Rotation.from_rotvec(p[:3]).as_matrix().T) * d, axis=1) - p[3]

    res = least_squares(fun, np.r_[np.zeros(3), float(np.mean(np.sum(v * d, axis=1)))], method="lm",
                        xtol=1e-13, ftol=1e-13, gtol=1e-13)
    J, r = res.jac, res.fun
    span = int(rows.max() - rows.min()) + 1
    label = ((rows - rows.min()) * BLOCKS) // span
    present = np.unique(label)
    G = len(present)
    A_inv = np.linalg.pinv(J.T @ J)
    scores = np.array([J[label == b].T @ r[label == b] for b in present])
    student = float(stdtrit(G - 1, 1.0 - OUTSIDE_ONE_SIGMA / 2)) ** 2 if G > 1 else np.inf
    clustered = A_inv @ (scores.T @ scores) @ A_inv * G / max(G - 1, 1) * student
    plain = A_inv * float(r @ r) / max(len(r) - 4, 1)
    factor = float(np.mean(np.diag(clustered) / np.where(np.diag(plain) > 0, np.diag(plain), np.inf)))
    cov = clustered if factor >= 1 else plain
    return res.x[:3], float(res.x[3]), cov, max(factor, 1.0), G, float(np.sqrt(np.mean(r ** 2)))
