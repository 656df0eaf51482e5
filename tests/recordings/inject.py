"""Known effects added to a real recording (issue 13, item 5), written from the vocabulary's laws (effects.md), at the
typical sizes of effects-research.md section 4: the analysis must find them blind on top of the real noise."""

from __future__ import annotations

import copy

import numpy as np

from rig.calibration.recording import RecordingCalibration
from rig.session_data import SessionData

G0 = 9.80665
DEG = np.pi / 180
SIZES = {"gyro_g_sensitivity": (0.05, 0.1),          # deg/s per g (ITG-3200 class)
         "bias_drift": (1.0, 3.0),                   # deg/s per hour on the gyro (a temperature ramp)
         "time_offset": (0.003, 0.02),               # s, the gyro stream late
         "accel_scale_nonlinearity": (1.5e-4, 5e-4)}  # 1/(m/s^2)


def _calibrated(session: SessionData, rec: RecordingCalibration, sensor: str) -> np.ndarray:
    y = session.raw[sensor].copy()
    have = ~np.isnan(y).any(axis=1)
    for k in range(3):
        y[:, k] = np.interp(session.t, session.t[have], y[have, k])
    return rec.sensors[sensor].apply(y)


def _raw(rec: RecordingCalibration, sensor: str, u: np.ndarray) -> np.ndarray:
    cal = rec.sensors[sensor]
    return u @ np.linalg.inv(cal.H).T + cal.B


def inject(session: SessionData, rec: RecordingCalibration, effect: str, size: float, rng) -> tuple[SessionData, dict]:
    """A copy of the recording with `effect` of `size` (the vocabulary's magnitude) added; and what was added."""
    out = copy.copy(session)
    out.raw = dict(session.raw)
    if effect == "gyro_g_sensitivity":
        A = rng.normal(size=(3, 3))
        A *= size / np.linalg.svd(A, compute_uv=False)[0]             # deg/s per g, largest singular value = size
        f = _calibrated(session, rec, "accel")
        w = _calibrated(session, rec, "gyro") + (f / G0) @ A.T * DEG
        out.raw["gyro"] = _keep_gaps(session.raw["gyro"], _raw(rec, "gyro", w))
        return out, {"G_deg_s_per_g": A}
    if effect == "bias_drift":
        d = rng.normal(size=3)
        d *= size / np.abs(d).max()                                    # deg/s per hour, largest axis = size
        w = _calibrated(session, rec, "gyro") + np.outer((session.t - session.t.mean()) / 3600, d) * DEG
        out.raw["gyro"] = _keep_gaps(session.raw["gyro"], _raw(rec, "gyro", w))
        return out, {"d_deg_s_per_hour": d}
    if effect == "time_offset":
        y = session.raw["gyro"]
        have = ~np.isnan(y).any(axis=1)
        late = np.stack([np.interp(session.t - size, session.t[have], y[have, k]) for k in range(3)], axis=1)
        out.raw["gyro"] = _keep_gaps(y, late)
        return out, {"tau_s": size}
    if effect == "accel_scale_nonlinearity":
        K2 = rng.uniform(0.5, 1.0, 3) * size * rng.choice([-1, 1], 3)
        K2[np.argmax(np.abs(K2))] = size * np.sign(K2[np.argmax(np.abs(K2))])
        a = _calibrated(session, rec, "accel")
        out.raw["accel"] = _keep_gaps(session.raw["accel"], _raw(rec, "accel", a + K2 * a ** 2))
        return out, {"K2": K2}
    raise ValueError(effect)


def _keep_gaps(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    after = after.copy()
    after[np.isnan(before).any(axis=1)] = np.nan
    return after
