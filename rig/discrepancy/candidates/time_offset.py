"""The discrepancy analysis's tests of `time_offset` (latency between sensor samples and the reference): on a
turntable session against the table's rate, in a recording against the accelerometer."""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from rig.calibration.recording import RecordingCalibration
from rig.discrepancy.candidates_base import Candidate, candidate_test
from rig.discrepancy.recording_base import Test, recording_test, subsample
from rig.session_data import SessionData, filled

TAU_MAX_S = 0.1               # s: the largest delay looked for (sample-clock offsets of loggers, filters' delays)


@candidate_test("time_offset", needs=("moves",))
def time_offset(sensor: str) -> Candidate:
    return Candidate(lambda o, f: -o.rate_dot[:, :, None], ("t",), lambda c: float(c[0]), lambda c: {"tau_s": float(c[0])},
                     note="sensor reads omega(t - tau): residual = -tau d(omega)/dt",
                     against=lambda o: (np.degrees(o.rate_dot), "reference d(omega)/dt, deg/s^2"))


@recording_test("time_offset")
def in_a_recording(session: SessionData, rec: RecordingCalibration, table: dict,
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
    taus = np.array(taus) if rng is None else rng.choice(taus, subsample(len(taus)), replace=False)
    mean, se = float(taus.mean()), float(taus.std(ddof=1) / np.sqrt(len(taus)))
    p = float(2 * stats.t.sf(abs(mean) / se, len(taus) - 1)) if se > 0 else 1.0
    return [Test("time_offset", "gyro", p, mean, se,
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
