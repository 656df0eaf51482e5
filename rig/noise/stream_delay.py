"""The delay between a recording's gyro stream and the streams that see a direction (the accelerometer gravity's,
the magnetometer the field's), from the motions alone: no turntable, no reference clock.

A direction d fixed in the world, seen in the body, turns as d' = -w x d (w the body rate). Read late by tau, the
gyro makes that hold only for w(t + tau); the tau of least sum |d' + w(t + tau) x d|^2 over a motion is that
motion's delay (the idea of Furgale, Rehder and Siegwart, "Unified temporal and spatial calibration for
multi-sensor systems", IROS 2013, eq. 7-9: one continuous-time trajectory, each stream's residual evaluated at its
own shifted time; here the trajectory is the gyro's own rate and the direction stream's residual is its derivative).

Both streams are low-passed alike (a Gaussian of `SMOOTH_S`, zero phase: no lag of its own): a hand's tremor
(8-12 Hz) and the noise would otherwise rule the derivative, and a lag of 40 ms is a third of a tremor's cycle,
which left several minima in a motion's cost (on the Xsens recording a fifth of the motions took one 30-100 ms
off). The accelerometer also reads the hand's acceleration, fitted as a lever arm in each motion. The motions'
delays, one each and independent, give the recording's by a robust mean with its standard deviation
(`robust_delay`): a few motions stay far off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rig.calibration.recordings.recording import RecordingCalibration
from rig.session_data import SessionData, filled

TAU_MAX_S = 0.1          # the largest delay looked for: loggers reading chips in turn, filters' group delays
SMOOTH_S = 0.08          # the Gaussian's standard deviation: tremor and noise out, a hand's motion (< 3 Hz) kept
HAND_SMOOTH_S = 0.02     # the hand's acceleration in a twin: the gyro's noise out of its derivative, the motion kept
MARGIN_S = 0.2           # of the still poses kept around a motion: its start and stop turn the direction too
MIN_TURN_RAD = math.radians(20.0)   # a motion that turns the direction less says little about the delay
MIN_MOTIONS = 6           # a delay is stated from this many motions on: its deviation is the motions' own scatter,
# and the scale of fewer (a median absolute deviation, 37 % efficient) is itself unsure by half: on imucal's five
# hand-turned motions a subsample of four named a delay in 18 resamples of 40
HUBER_K = 1.345       # 95 % efficiency at normal motions


@dataclass
class Delay:
    """A stream's delay behind another (s, positive: the gyro late), from its motions."""

    value: float                 # the motions' delays' robust mean (Huber)
    sd: float                    # its standard deviation
    dof: int                     # of that deviation's t distribution
    per_motion: list[float]


def recording_delays(session: SessionData, rec: RecordingCalibration) -> dict[str, Delay]:
    """The gyro's delay behind each calibrated direction sensor of the recording ("accel", "mag"), from its motions
    between poses and its turns; a sensor whose motions are too few is left out."""
    gyro = rec.sensors.get("gyro")
    if gyro is None or "gyro" not in session.raw:
        return {}
    spans = motion_spans(rec)
    if len(spans) < MIN_MOTIONS:
        return {}
    rate = gyro.apply(filled(session.raw["gyro"]))
    out = {}
    for sensor in ("accel", "mag"):
        if sensor in rec.sensors and sensor in session.raw:
            seen = rec.sensors[sensor].apply(filled(session.raw[sensor]))
            found = robust_delay(direction_delays(session.t, rate, seen, spans, lever=sensor == "accel"))
            if found is not None:
                out[sensor] = found
    return out


@dataclass
class MotionFit:
    """One motion's delay (s) and, for the accelerometer, the lever arm (m, body frame) fitted at it; `motion` its
    (first, last) row as given (the last row of the pose it leaves, the first of the one it reaches)."""

    motion: tuple[int, int]
    tau: float
    arm: np.ndarray | None


def direction_delays(t: np.ndarray, rate: np.ndarray, seen: np.ndarray, motions: list[tuple[int, int]], *,
                     lever: bool = False) -> list[float]:
    """Each motion's delay (`motion_fits`)."""
    return [fit.tau for fit in motion_fits(t, rate, seen, motions, lever=lever)]


def hand_acceleration(session: SessionData, rec: RecordingCalibration) -> np.ndarray | None:
    """(n, 3) the acceleration (m/s^2, body frame) each motion's fitted lever arm gives through the motion, at the
    gyro's own rate as recorded (the motion a twin replays), its derivative taken through HAND_SMOOTH_S:
    alpha x r + w x (w x r); none outside the motions. The fit's own smoothing (SMOOTH_S) here had been applied
    twice in a replica, whose delay then sat 0.25 ms from its recording's; none, and the gyro's noise
    differentiated filled the motions with noise of 0.1 m/s^2 that moved the accelerometer's value steps. What a twin's
    accelerometer reads beside gravity where the recording's hand turned the unit about a point away from it; None
    where the recording has no motions to fit."""
    gyro = rec.sensors.get("gyro")
    if gyro is None or "accel" not in rec.sensors or "gyro" not in session.raw:
        return None
    spans = motion_spans(rec)
    if len(spans) < MIN_MOTIONS:
        return None
    rate = gyro.apply(filled(session.raw["gyro"]))
    fits = motion_fits(session.t, rate, rec.sensors["accel"].apply(filled(session.raw["accel"])), spans, lever=True)
    w = _smoothed(rate, _kernel(float(np.median(np.diff(session.t))), HAND_SMOOTH_S))
    alpha = np.gradient(w, session.t, axis=0)
    out = np.zeros_like(rate)
    for fit in fits:
        rows = slice(fit.motion[0] + 1, fit.motion[1])        # between the poses: a held pose reads none
        out[rows] = np.cross(alpha[rows], fit.arm) + np.cross(w[rows], np.cross(w[rows], fit.arm))
    return out


def motion_spans(rec: RecordingCalibration) -> list[tuple[int, int]]:
    """(first row, last row) of every motion between consecutive poses and of every turn."""
    spans = [(rec.poses[i].rows[-1], rec.poses[j].rows[0]) for i, j in rec.carries]
    return spans + [(turn.rows[0], turn.rows[-1]) for turn in rec.turns]


def motion_fits(t: np.ndarray, rate: np.ndarray, seen: np.ndarray, motions: list[tuple[int, int]], *,
                lever: bool = False) -> list[MotionFit]:
    """The gyro's delay (s) behind the stream `seen` (n, 3) of a vector fixed in the world (gravity's specific
    force, the field), and with `lever` the arm fitted at it, in each motion (first row, last row) that turns it by
    MIN_TURN_RAD or more; `rate` (n, 3) the calibrated rate in the same frame (rad/s), both without gaps. The motions'
    rows are widened by MARGIN_S and, for the filter and the shifts, by as much again as they reach, within the
    recording.

    The law is v' + w(t + tau) x v = 0. With `lever` (the accelerometer) the sensor may sit a lever arm r from the
    point the hand turns about, and reads that point's acceleration a = alpha x r + w x (w x r) beside gravity:
    the law is then v' + w x v = w x a + a' = M(w, alpha, alpha') r, with r fitted in each motion at each tau (a
    hand's grip is fixed through one motion). Without it, a lever arm of 15 cm threw the motions' delays of a
    synthetic hand 40 ms either way, and a lag of 40 ms came out at 31 +- 9 ms."""
    n = len(t)
    dt = float(np.median(np.diff(t)))
    reach = max(int(math.ceil(TAU_MAX_S / dt)), 1)
    kernel = _kernel(dt)
    half = len(kernel) // 2
    margin = max(int(round(MARGIN_S / dt)), 1)
    shifts = np.arange(-reach, reach + 1)
    out = []
    for first, last in motions:
        a, b = max(first - margin, 0), min(last + margin, n - 1)
        lo, hi = max(a - reach - half, 0), min(b + reach + half, n - 1)
        if a - lo < reach or hi - b < reach:
            continue                                    # too near the recording's ends to shift
        rows = slice(lo, hi + 1)
        w = _smoothed(rate[rows], kernel)
        v = _smoothed(seen[rows], kernel)
        inner = slice(a - lo, b - lo + 1)
        direction = v[inner] / np.linalg.norm(v[inner], axis=1, keepdims=True)
        if float(np.sum(np.linalg.norm(np.cross(w[inner], direction), axis=1)) * dt) < MIN_TURN_RAD:
            continue
        dv = np.gradient(v, t[rows], axis=0)[inner]
        shifted = np.stack([w[inner.start + k:inner.stop + k] for k in shifts])          # w(t + k dt)
        residual = dv + np.cross(shifted, v[inner])                                       # (K, m, 3)
        costs = np.sum(residual ** 2, axis=(1, 2))
        arm = None
        if lever:                      # the least-squares arm at each shift: costs less what it explains
            alpha = np.gradient(w, t[rows], axis=0)
            M = _lever_matrix(w, alpha, np.gradient(alpha, t[rows], axis=0))
            m = inner.stop - inner.start
            windows = np.lib.stride_tricks.sliding_window_view(M, m, axis=0)[inner.start + shifts]   # (K, 3, 3, m)
            summed = np.cumsum(np.concatenate([np.zeros((1, 3, 3)), np.einsum("nji,njl->nil", M, M)]), axis=0)
            normal = summed[inner.stop + shifts] - summed[inner.start + shifts]
            projected = np.einsum("kjim,kmj->ki", windows, residual)
            scale = np.trace(normal, axis1=1, axis2=2)[:, None, None]
            arm = np.linalg.solve(normal + 1e-12 * scale * np.eye(3), projected[..., None])[..., 0]
            costs = costs - np.sum(projected * arm, axis=1)
        i = int(np.argmin(costs))
        if i in (0, len(shifts) - 1):
            continue                                    # no minimum within the reach
        c0, c1, c2 = costs[i - 1], costs[i], costs[i + 1]
        curve = c0 - 2 * c1 + c2
        tau = float((shifts[i] + (0.5 * (c0 - c2) / curve if curve > 0 else 0.0)) * dt)
        out.append(MotionFit((first, last), tau, None if arm is None else arm[i]))
    return out


def _kernel(dt: float, width_s: float = SMOOTH_S) -> np.ndarray:
    """The Gaussian of `width_s` at a sample interval dt, out to four of its deviations, summing to one."""
    sigma = max(width_s / dt, 0.5)
    half = int(math.ceil(4 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    return kernel / kernel.sum()


def _lever_matrix(w: np.ndarray, alpha: np.ndarray, jerk: np.ndarray) -> np.ndarray:
    """M (..., 3, 3) with w x a + a' = M r for a = alpha x r + w x (w x r), r fixed in the body:
    [jerk]x + [alpha]x [w]x + 2 [w]x [alpha]x + [w]x^3."""
    W, A, J = _cross_matrix(w), _cross_matrix(alpha), _cross_matrix(jerk)
    return J + A @ W + 2 * W @ A + W @ W @ W


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def robust_delay(per_motion: list[float]) -> Delay | None:
    """The motions' delays as one, with its standard deviation: Huber's M-estimate of their location (Huber 1964,
    "Robust estimation of a location parameter", Ann. Math. Statist. 35, eq. 3 with psi(r) = clip(r, -k, k),
    k = 1.345, the scale the median absolute deviation's) and its asymptotic deviation,
    s sqrt(mean(psi^2) / (n - 1)) / mean(psi'), on n - 1 degrees of freedom. A motion a hand's linear acceleration
    threw off weighs as one at the edge, not as its distance; a 20 % trimmed mean had left a five-motion recording
    two degrees of freedom."""
    x = np.sort(np.asarray(per_motion, dtype=float))
    n = len(x)
    if n < MIN_MOTIONS:
        return None
    centre = float(np.median(x))
    scale = 1.4826 * float(np.median(np.abs(x - centre))) or float(np.std(x, ddof=1)) or 1e-12
    for _ in range(100):
        step = scale * float(np.mean(np.clip((x - centre) / scale, -HUBER_K, HUBER_K)))
        centre += step
        if abs(step) <= 1e-12 * scale:
            break
    r = (x - centre) / scale
    psi = np.clip(r, -HUBER_K, HUBER_K)
    slope = float(np.mean(np.abs(r) < HUBER_K))
    sd = scale * float(np.sqrt(np.mean(psi ** 2) / (n - 1))) / slope
    return Delay(centre, sd, n - 1, x.tolist())


def _smoothed(y: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    half = len(kernel) // 2
    padded = np.pad(y, ((half, half), (0, 0)), mode="edge")
    return np.stack([np.convolve(padded[:, k], kernel, mode="valid") for k in range(y.shape[1])], axis=1)
