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

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from rig.calibration.recording import RecordingCalibration
from rig.session_data import SessionData, filled

ALPHA = 0.01
G0 = 9.80665
DEG = math.pi / 180
TAU_MAX_S = 0.1               # s: the largest delay looked for (sample-clock offsets of loggers, filters' delays)


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
    for name in blocks:
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
    """|a| - g of the poses that are not faces against the even term K2 u^2, beyond what B and H absorb.

    measured = u + K2 u^2 per axis moves |a| by sum_i K2_i u_i^3 / |u| (first order); a bias and a matrix move
    it along u_i / |u| and u_i u_j / |u|, which the calibration has already fitted away, so the test uses the
    part of the cubic signature those cannot make (Frisch-Waugh) and says how much of it the fit absorbs.
    """
    free = ~table["face"]
    if free.sum() < 16:
        return []
    f = table["f"][free]
    size = np.linalg.norm(f, axis=1)
    r = (size - norm)[:, None]
    unit = f / size[:, None]
    linear = np.column_stack([unit] + [unit[:, i] * f[:, j] for i in range(3) for j in range(i, 3)])
    cubic = f ** 3 / size[:, None]
    p, coef, cov = _nested_f(np.hstack([linear, cubic]), linear, r)
    K2 = coef[-3:, 0]
    unc = float(np.sqrt(np.max(np.diag(cov)[-3:]) * _resvar(np.hstack([linear, cubic]), r)[0]))
    kept = np.linalg.norm(cubic - linear @ np.linalg.lstsq(linear, cubic, rcond=None)[0]) / np.linalg.norm(cubic)
    return [Test("accel_scale_nonlinearity", "accel", p, float(np.abs(K2).max()), "1/(m/s^2)", unc,
                 {"K2": K2.tolist(), "identifiable": float(kept)})]


def time_offset_test(session: SessionData, rec: RecordingCalibration,
                     rng: np.random.Generator | None = None) -> list[Test]:
    """The gyro's delay against the accelerometer, one estimate per motion, tested across motions (t test).

    In a motion the gravity direction seen by the body turns as g' = -w x g; the gyro read tau late makes
    that hold only for w(t + tau). Each motion's tau minimises sum |g' + w(t + tau) x g|^2 (both streams
    smoothed alike, so the filter adds no lag); the motions' estimates, independent, give the mean and its
    standard error. A summed rotation (carried gravity, a turn's angle) cannot see tau: it integrates through.
    """
    if "gyro" not in rec.sensors or "accel" not in rec.sensors:
        return []
    dt = float(np.median(np.diff(session.t)))
    taus = []
    for rows in _motions(session, rec):
        tau = _motion_delay(session, rec, rows, dt)
        if tau is not None:
            taus.append(tau)
    if len(taus) < 4:
        return []
    taus = np.array(taus) if rng is None else rng.choice(taus, _subsample(len(taus)), replace=False)
    mean, se = float(taus.mean()), float(taus.std(ddof=1) / np.sqrt(len(taus)))
    p = float(2 * stats.t.sf(abs(mean) / se, len(taus) - 1)) if se > 0 else 1.0
    return [Test("time_offset", "gyro", p, mean, "s", se,
                 {"per_motion_s": taus.tolist(), "positive": "gyro lags the accelerometer"})]


def _motions(session: SessionData, rec: RecordingCalibration) -> list[np.ndarray]:
    """Rows of every motion between consecutive poses and of every turn, with a little of the stills around."""
    margin = max(round(0.2 / float(np.median(np.diff(session.t)))), 1)
    spans = [(rec.poses[i].rows[-1] - margin, rec.poses[j].rows[0] + margin) for i, j in rec.carries]
    spans += [(t.rows[0] - margin, t.rows[-1] + margin) for t in rec.turns]
    n = len(session.t)
    return [np.arange(max(a, 0), min(b, n - 1) + 1) for a, b in spans if b - a > 4 * margin]


def _motion_delay(session: SessionData, rec: RecordingCalibration, rows: np.ndarray, dt: float) -> float | None:
    t = session.t[rows]
    a = rec.sensors["accel"].apply(filled(session.raw["accel"][rows]))
    w = rec.sensors["gyro"].apply(filled(session.raw["gyro"][rows]))
    width = max(round(0.05 / dt), 1)
    a, w = _smooth(a, width), _smooth(w, width)
    g = a / np.linalg.norm(a, axis=1, keepdims=True)
    dg = np.gradient(g, t, axis=0)
    if np.sum(np.linalg.norm(np.cross(w, g), axis=1) * dt) < math.radians(20):
        return None                                    # the motion barely turns gravity: no information on tau
    reach = math.ceil(TAU_MAX_S / dt)
    inner = slice(reach, len(t) - reach)
    if inner.stop - inner.start < 10:
        return None
    grid = np.arange(-reach, reach + 1) * dt
    costs = []
    for tau in grid:
        w_tau = np.stack([np.interp(t[inner] + tau, t, w[:, k]) for k in range(3)], axis=1)
        costs.append(float(np.sum((dg[inner] + np.cross(w_tau, g[inner])) ** 2)))
    i = int(np.argmin(costs))
    if i in (0, len(grid) - 1):
        return None                                    # no minimum inside the scan
    c0, c1, c2 = costs[i - 1], costs[i], costs[i + 1]
    curve = c0 - 2 * c1 + c2
    return float(grid[i] + (0.5 * (c0 - c2) / curve * dt if curve > 0 else 0.0))


def _smooth(y: np.ndarray, width: int) -> np.ndarray:
    kernel = np.ones(width) / width
    return np.stack([np.convolve(y[:, k], kernel, mode="same") for k in range(3)], axis=1)


def recording_tests(session: SessionData, rec: RecordingCalibration, *, time_offset: bool = True,
                    rng: np.random.Generator | None = None) -> list[dict]:
    """Every test the recording supports, Holm-corrected; each as a finding candidate with `significant`.

    With `rng`, one subsample (the m-out-of-n bootstrap of Politis and Romano, m = 80 %, without replacement: a
    pose drawn twice would count as two independent ones in the tests): how stable the named set is under the
    recording's own scatter of poses and motions."""
    table = pose_table(session, rec)
    if rng is not None:
        pick = np.sort(rng.choice(len(table["t"]), _subsample(len(table["t"])), replace=False))
        table = {k: v[pick] for k, v in table.items()}
    tests = gyro_pose_tests(table) + accel_nonlinearity_test(table, session.gravity)
    if time_offset:
        tests += time_offset_test(session, rec, rng)
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


def _subsample(n: int) -> int:
    return max(int(0.8 * n), 1)


def _mean(v: np.ndarray) -> np.ndarray:
    return v[~np.isnan(v).any(axis=1)].mean(axis=0)
