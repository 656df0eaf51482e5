"""What the linear model misses in a recording without a turntable, named in the effects.md vocabulary.

No reference orientation exists, so the tests use what the recording itself fixes: the calibrated specific force
of every static pose (the accelerometer tells how gravity lay), the pose's time, and the motions between poses
whose gravity the gyro must carry (imu_tk's criterion):
- `gyro_g_sensitivity` and `bias_drift` (gyro): the poses' calibrated gyro means regressed on [1, f, t] by
  ordinary least squares, each block tested by its nested F test against the model without it;
- `time_offset` (gyro against accelerometer): the gyro stream shifted by tau, the gyro refitted, the misfit of
  the turns and carried gravity scanned over tau; the minimum against tau = 0 by an F test;
- `accel_scale_nonlinearity`: the poses' |a| - g against the squared calibrated components, where poses are
  not faces (a face's fitted tilt meets |a| = g by construction, and six faces cannot tell an even term from a
  bias).
p-values are Holm-corrected over the tests run; a finding needs p < ALPHA after correction.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from rig.calibration.recording import RecordingCalibration, fit_gyro
from rig.errors import CalibrationError
from rig.session_data import SessionData

ALPHA = 0.01
G0 = 9.80665
DEG = math.pi / 180
TAU_SCAN_S = np.linspace(-0.05, 0.05, 21)      # s: sample-clock offsets of loggers and filters' delays


@dataclass
class Test:
    effect: str
    sensor: str
    p: float
    magnitude: float
    unit: str
    uncertainty: float
    params: dict


def pose_table(session: SessionData, rec: RecordingCalibration) -> dict[str, np.ndarray]:
    """Per static pose: mid time, calibrated specific force (m/s^2) and gyro mean (rad/s)."""
    acc, gyr = rec.sensors["accel"], rec.sensors.get("gyro")
    rows = [p.rows for p in rec.poses]
    out = {"t": np.array([session.t[r].mean() for r in rows]),
           "f": np.array([acc.apply(_mean(session.raw["accel"][r])[None])[0] for r in rows]),
           "face": np.array([p.up is not None for p in rec.poses])}
    if gyr is not None:
        out["w"] = np.array([gyr.apply(_mean(session.raw["gyro"][r])[None])[0] for r in rows])
    return out


def gyro_pose_tests(table: dict) -> list[Test]:
    """g-sensitivity and bias drift of the gyro from the pose means, each against the model without it."""
    if "w" not in table:
        return []
    k = len(table["t"])
    ones = np.ones((k, 1))
    f = table["f"] / G0
    t = (table["t"] - table["t"].mean())[:, None] / 3600.0
    blocks = {"gyro_g_sensitivity": f, "bias_drift": t}
    full = np.hstack([ones, f, t])
    if k <= full.shape[1] + 1:
        blocks.pop("bias_drift")
        full = np.hstack([ones, f])
        if k <= full.shape[1] + 1:
            return []
    w = table["w"] / DEG
    tests = []
    for name, block in blocks.items():
        reduced = np.hstack([ones] + [b for n, b in blocks.items() if n != name])
        p, coef, cov = _nested_f(full, reduced, w)
        idx = slice(1, 4) if name == "gyro_g_sensitivity" else slice(full.shape[1] - 1, full.shape[1])
        c = coef[idx]                                        # (q, 3): deg/s per g, or deg/s per hour
        if name == "gyro_g_sensitivity":
            mag = float(np.linalg.svd(c.T, compute_uv=False)[0])
            unc = float(np.sqrt(np.max(np.diag(cov)[idx]) * np.mean(_resvar(full, w))))
            tests.append(Test(name, "gyro", p, mag, "deg/s per g", unc, {"G_deg_s_per_g": c.T.tolist()}))
        else:
            mag = float(np.abs(c).max())
            unc = float(np.sqrt(np.diag(cov)[idx][0] * np.max(_resvar(full, w))))
            tests.append(Test(name, "gyro", p, mag, "deg/s per hour", unc, {"d_deg_s_per_hour": c[0].tolist()}))
    return tests


def accel_nonlinearity_test(table: dict, norm: float) -> list[Test]:
    """|a| - g of the poses that are not faces against the squared components (the even term K2 u^2)."""
    free = ~table["face"]
    if free.sum() < 8:
        return []
    f = table["f"][free]
    r = np.linalg.norm(f, axis=1) - norm
    # measured = true + K2 true^2 per axis moves |a| by sum_i K2_i f_i^3 / |f| (to first order)
    X_full = np.column_stack([np.ones(len(f)), f ** 3 / np.linalg.norm(f, axis=1)[:, None]])
    X_red = X_full[:, :1]
    p, coef, cov = _nested_f(X_full, X_red, r[:, None])
    K2 = coef[1:4, 0]
    unc = float(np.sqrt(np.max(np.diag(cov)[1:4]) * _resvar(X_full, r[:, None])[0]))
    return [Test("accel_scale_nonlinearity", "accel", p, float(np.abs(K2).max()), "1/(m/s^2)", unc,
                 {"K2": K2.tolist()})]


def time_offset_test(session: SessionData, rec: RecordingCalibration) -> list[Test]:
    """The gyro's delay against the accelerometer, from the misfit of turns and carried gravity over a scan."""
    if "gyro" not in rec.sensors or (not rec.turns and not rec.carries):
        return []
    costs, m = [], None
    for tau in TAU_SCAN_S:
        shifted = _shifted(session, "gyro", tau)
        try:
            g, _ = fit_gyro(shifted, rec.sensors["accel"], rec.poses, rec.turns, rec.carries, {})
        except CalibrationError:
            costs.append(np.inf)
            continue
        r = np.radians(np.r_[g.extra.get("turn_angle_error_deg", []), g.extra.get("carry_error_deg", [])])
        m = len(r)
        costs.append(float(r @ r))
    costs = np.array(costs)
    if m is None or m <= 11 or not np.isfinite(costs).any():
        return []
    i = int(np.nanargmin(costs))
    c0 = costs[len(TAU_SCAN_S) // 2]
    dof = m - 10
    F = max((c0 - costs[i]) / (costs[i] / dof), 0.0)
    p = float(stats.f.sf(F, 1, dof))
    tau = float(TAU_SCAN_S[i])
    return [Test("time_offset", "gyro", p, tau, "s", float(TAU_SCAN_S[1] - TAU_SCAN_S[0]),
                 {"scan_s": TAU_SCAN_S.tolist(), "misfit": costs.tolist(), "positive": "gyro lags the accelerometer"})]


def recording_tests(session: SessionData, rec: RecordingCalibration, *, time_offset: bool = True) -> list[dict]:
    """Every test the recording supports, Holm-corrected; each as a finding candidate with `significant`."""
    table = pose_table(session, rec)
    tests = gyro_pose_tests(table) + accel_nonlinearity_test(table, session.gravity)
    if time_offset:
        tests += time_offset_test(session, rec)
    order = np.argsort([t.p for t in tests])
    holm = np.zeros(len(tests))
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(tests) - rank) * tests[i].p))
        holm[i] = running
    return [{"effect": t.effect, "sensor": t.sensor, "magnitude": t.magnitude, "unit": t.unit,
             "uncertainty": t.uncertainty, "p": t.p, "p_holm": float(h), "significant": bool(h < ALPHA),
             "params": t.params} for t, h in zip(tests, holm)]


def _nested_f(X_full: np.ndarray, X_red: np.ndarray, y: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """p of the nested F test (all response columns pooled), the full model's coefficients and (X^T X)^-1."""
    n, p_full = X_full.shape
    coef, *_ = np.linalg.lstsq(X_full, y, rcond=None)
    red, *_ = np.linalg.lstsq(X_red, y, rcond=None)
    rss_full = float(np.sum((y - X_full @ coef) ** 2))
    rss_red = float(np.sum((y - X_red @ red) ** 2))
    q = (p_full - X_red.shape[1]) * y.shape[1]
    dof = (n - p_full) * y.shape[1]
    if dof <= 0 or rss_full <= 0:
        return 1.0, coef, np.linalg.pinv(X_full.T @ X_full)
    F = ((rss_red - rss_full) / q) / (rss_full / dof)
    return float(stats.f.sf(F, q, dof)), coef, np.linalg.pinv(X_full.T @ X_full)


def _resvar(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return np.sum((y - X @ coef) ** 2, axis=0) / max(len(y) - X.shape[1], 1)


def _shifted(session: SessionData, sensor: str, tau: float) -> SessionData:
    """The session with one stream read tau later: y'(t) = y(t + tau)."""
    out = copy.copy(session)
    y = session.raw[sensor]
    have = ~np.isnan(y).any(axis=1)
    shifted = np.stack([np.interp(session.t + tau, session.t[have], y[have, k]) for k in range(3)], axis=1)
    shifted[~have] = np.nan
    out.raw = dict(session.raw, **{sensor: shifted})
    return out


def _mean(v: np.ndarray) -> np.ndarray:
    return v[~np.isnan(v).any(axis=1)].mean(axis=0)
