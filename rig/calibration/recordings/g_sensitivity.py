"""A recording's gyro g-sensitivity taken into its calibration, where the recording shows one.

A MEMS gyro's proof mass answers to specific force: its rate at rest depends on how gravity lies
(effects.md `gyro_g_sensitivity`; the Xsens MTi's pose means follow it at 0.2 deg/s per g). Left out of the model,
that rate is integrated across every motion between poses and the gravity it carries arrives off (held out motion
by motion in benchmarks/bench_recordings.py). The fit is the discrepancy analysis's test of it
(`rig.discrepancy.recording`): the calibrated gyro's pose means regressed on [1, f, t] (t so a drifting bias is not
taken for it), the f block kept where its nested F test gives p < ALPHA. The gyro is then fitted again on the rate
less `K (f - f_ref)`, f_ref the poses' average specific force, so B stays the bias over the poses. The vertical Earth
rate aliases into it as an isotropic -(Omega_v / g) I, at most 0.004 deg/s per g (at a pole).
"""

from __future__ import annotations

import copy
from collections.abc import Callable

import numpy as np

from rig.calibration.numerics.result import GSensitivity, TriadCalibration
from rig.calibration.numerics.regression import nested_f
from rig.session_data import SessionData, filled
from rig.units import DEG, STANDARD_GRAVITY

ALPHA = 0.01                # as the discrepancy analysis names an effect
MIN_DOF = 2                 # per axis, after the 5 columns [1, f, t]


def pose_means(session: SessionData, sensors: dict[str, TriadCalibration],
               pose_rows: list[np.ndarray]) -> dict[str, np.ndarray]:
    """Per pose: mid time `t` (s), calibrated specific force `f` (m/s^2) and, with a gyro, its calibrated mean
    rate `w` (rad/s): what the g-sensitivity fit here and the discrepancy analysis's pose tests regress."""
    out = {"t": np.array([session.t[r].mean() for r in pose_rows]),
           "f": np.array([sensors["accel"].apply(_mean(session.raw["accel"][r]))[0] for r in pose_rows])}
    if "gyro" in sensors:
        out["w"] = np.array([sensors["gyro"].apply(_mean(session.raw["gyro"][r]))[0] for r in pose_rows])
    return out


def fit_g_sensitivity(session: SessionData, sensors: dict[str, TriadCalibration],
                      pose_rows: list[np.ndarray]) -> GSensitivity | None:
    """K (raw gyro unit per m/s^2) from the poses' means, or None where the poses are too few or it is not
    significant."""
    if "gyro" not in sensors or "accel" not in sensors:
        return None
    if len(pose_rows) < 5 + MIN_DOF:
        return None
    accel, gyro = sensors["accel"], sensors["gyro"]
    means = pose_means(session, sensors, pose_rows)
    f, w, t = means["f"], means["w"], means["t"]
    ones, hours = np.ones((len(t), 1)), (t - t.mean())[:, None] / 3600.0
    p, coef, _ = nested_f(np.hstack([ones, f, hours]), np.hstack([ones, hours]), w)
    if not p < ALPHA:
        return None
    G = coef[1:4].T                                       # rad/s per m/s^2
    stills = np.concatenate(pose_rows)
    f_ref = np.nanmean(accel.apply(session.raw["accel"][stills]), axis=0)
    return GSensitivity(K=np.linalg.solve(gyro.H, G), f_ref=f_ref, p_value=p, poses=len(pose_rows),
                        deg_s_per_g=float(np.linalg.svd(G, compute_uv=False)[0] * STANDARD_GRAVITY / DEG))


def without_g_sensitivity(session: SessionData, accel: TriadCalibration, g: GSensitivity) -> SessionData:
    """The session with the rate the g-sensitivity adds taken out of the raw gyro, row by row."""
    out = copy.copy(session)
    out.raw = dict(session.raw, gyro=session.raw["gyro"] - g.raw_rate(accel.apply(filled(session.raw["accel"]))))
    return out


def with_g_sensitivity(session: SessionData, sensors: dict[str, TriadCalibration], pose_rows: list[np.ndarray],
                       refit: Callable[[SessionData], TriadCalibration]) -> TriadCalibration | None:
    """The gyro refitted on the corrected rate, carrying its g-sensitivity; None where there is none to take."""
    g = fit_g_sensitivity(session, sensors, pose_rows)
    if g is None:
        return None
    gyro = refit(without_g_sensitivity(session, sensors["accel"], g))
    gyro.g_sensitivity = g
    return gyro


def _mean(v: np.ndarray) -> np.ndarray:
    return v[~np.isnan(v).any(axis=1)].mean(axis=0, keepdims=True)
