"""What of an accelerometer's disturbed holds the gyro agrees is a rotation, and what is not (effects.md: a pose that is
"not still" is a rotation, which a gyro present must read; linear shaking the gyro does not see is `vibration`).

A hand that turns a held unit by a small angle theta(t) tilts the specific force it reads by f x theta: in each band
of frequency the accelerometer then shows g^2 |w(f)|^2 / (2 pi f)^2 of the gyro's rate w across gravity. Per pose
and octave band, the accelerometer's variance beyond its quiet poses' is set beside what the gyro's rate in the same
rows gives through that law, less what the gyro's own white noise gives through it; what the gyro's rate cannot
give, even at the top of its uncertainty, is not a rotation: a linear acceleration (a motor, a fan, a hand pushing)
or a noise of the accelerometer's own in those poses. Its bands say where it lies, its variance how large it is.

The gyro's rate is the calibrated gyro's, or, where the gyro could not be calibrated but was recorded in rad/s or
deg/s, its own reading less each pose's mean (a gain error of a few percent, a misalignment of a few degrees, do not
change a comparison of orders of magnitude). A gyro in counts that could not be calibrated says no rate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from procedures.twin.noise import quiet_poses
from rig.calibration.recordings.recording import RecordingCalibration
from rig.session_data import SessionData
from rig.units import DEG

LOWEST_HZ = 0.25           # the lowest octave's lower edge: a pose of a few seconds resolves no slower shake
BOUND_SIGMAS = 2.0         # the rotation's share is taken at the top of its uncertainty before anything is vibration
RATE_UNITS = {"rad/s": 1.0, "deg/s": DEG}


@dataclass
class Split:
    """The accelerometer's excess over its quiet poses, pooled over the poses and axes, per octave band (m/s^2)^2, and
    the share of it the gyro's rotation can give."""

    edges: np.ndarray                 # (B + 1,) Hz
    excess: np.ndarray                # (B,) variance beyond the quiet poses'
    rotation: np.ndarray              # (B,) of it, what the gyro's rate gives (at the top of its uncertainty)
    excess_sd: np.ndarray             # (B,) the excess's standard deviation (its periodograms')

    @property
    def rotation_share(self) -> float:
        total = float(self.excess.sum())
        return float(self.rotation.sum() / total) if total > 0 else 1.0

    @property
    def linear(self) -> np.ndarray:
        return np.maximum(self.excess - self.rotation, 0.0)

    @property
    def linear_sigmas(self) -> float:
        """How many of its standard deviations the part no rotation gives stands above none."""
        sd = float(np.sqrt(np.sum(self.excess_sd ** 2)))
        return float(self.linear.sum() / sd) if sd > 0 else 0.0

    def band_hz(self, part: np.ndarray | None = None, share: float = 0.8) -> tuple[float, float]:
        """The frequencies between which the central `share` of `part` (per band; the linear part by default) lies,
        log-interpolated within the bands."""
        part = self.linear if part is None else part
        if part.sum() <= 0:
            return float(self.edges[0]), float(self.edges[-1])
        cumulative = np.r_[0.0, np.cumsum(part)] / part.sum()
        logs = np.log(self.edges)
        lo, hi = np.interp([(1 - share) / 2, (1 + share) / 2], cumulative, logs)
        return float(math.exp(lo)), float(math.exp(hi))


    def taps(self, rate_hz: float, part: np.ndarray | None = None, length: int = 256) -> np.ndarray:
        """A linear-phase FIR whose power response is the spectrum `part` (per band, flat within each; the linear
        part by default): white noise through it has that spectral shape. 256 taps resolve the lowest octaves at
        100 Hz."""
        freq = np.fft.rfftfreq(length, 1.0 / rate_hz)
        density = (self.linear if part is None else part) / np.diff(self.edges)
        band = np.clip(np.searchsorted(self.edges, freq, side="right") - 1, 0, len(density) - 1)
        amplitude = np.where(freq >= self.edges[0], np.sqrt(density[band]), 0.0)
        if not amplitude.any():
            amplitude = np.ones_like(freq)
        taps = np.roll(np.fft.irfft(amplitude, length), length // 2) * np.hanning(length)
        return taps / np.linalg.norm(taps)


def rate_across_gravity(session: SessionData, rec: RecordingCalibration, rate: np.ndarray, rate_hz: float,
                        below_hz: float = 2.0) -> float:
    """RMS over the poses of the gyro's rate (rad/s) across gravity below `below_hz` (what the accelerometer would
    see turn), each pose's mean removed; its noise in that band left in (an upper bound of the rotation)."""
    cal = rec.sensors["accel"]
    out = []
    for pose in rec.poses:
        both = ~(np.isnan(session.raw["accel"][pose.rows]).any(axis=1) | np.isnan(rate[pose.rows]).any(axis=1))
        rows = pose.rows[both]
        if len(rows) < 16:
            continue
        up = cal.apply(session.raw["accel"][rows]).mean(axis=0)
        up /= np.linalg.norm(up)
        w = rate[rows] - rate[rows].mean(axis=0)
        across = w - np.outer(w @ up, up)
        spectrum = np.fft.rfft(across, axis=0)
        spectrum[np.fft.rfftfreq(len(rows), 1.0 / rate_hz) >= below_hz] = 0.0
        out.append(float(np.mean(np.sum(np.fft.irfft(spectrum, len(rows), axis=0) ** 2, axis=1))))
    return float(np.sqrt(np.mean(out))) if out else 0.0


def gyro_rate(session: SessionData, rec: RecordingCalibration) -> np.ndarray | None:
    """(n, 3) the gyro's rate in rad/s where the recording says it (`module docstring`), else None."""
    if "gyro" not in session.raw:
        return None
    if "gyro" in rec.sensors:
        return rec.sensors["gyro"].apply(session.raw["gyro"])
    scale = RATE_UNITS.get(session.meta.get("units", {}).get("gyro", "counts"))
    return None if scale is None else session.raw["gyro"] * scale


def split_by_gyro(session: SessionData, rec: RecordingCalibration, rate: np.ndarray, rate_hz: float) -> Split:
    """The accelerometer's disturbed holds set beside the gyro's rate in the same rows (module docstring): pooled over
    the poses not quiet on the accelerometer (`quiet_poses`), each by its samples. The quiet poses are those of least
    spread, whose level is low by their choice: pooled over every pose, a clean recording's excess was that bias."""
    edges = octaves(rate_hz)
    cal = rec.sensors["accel"]
    quiet = quiet_poses(session, rec, "accel")
    bands = len(edges) - 1
    accel, accel_sd = np.full((len(rec.poses), bands, 3), np.nan), np.zeros((len(rec.poses), bands, 3))
    left = np.zeros((len(rec.poses), bands))
    weights = np.zeros(len(rec.poses))
    for i, pose in enumerate(rec.poses):
        both = ~(np.isnan(session.raw["accel"][pose.rows]).any(axis=1) | np.isnan(rate[pose.rows]).any(axis=1))
        rows = pose.rows[both]
        if len(rows) < 16:
            continue
        u = cal.apply(session.raw["accel"][rows])
        accel[i], accel_sd[i] = band_variance(u, rate_hz, edges)
        left[i] = band_variance(not_turned(u, rate[rows], rate_hz), rate_hz, edges)[0].sum(axis=1)
        weights[i] = len(rows)
    floor = np.array([[np.nanmean(accel[quiet[:, k], b, k]) if (quiet[:, k] & (weights > 0)).any() else 0.0
                       for k in range(3)] for b in range(bands)])
    use = (weights > 0) & ~quiet.all(axis=1)
    if not use.any():
        return Split(edges, np.zeros(bands), np.zeros(bands), np.zeros(bands))
    w = weights[use] / weights[use].sum()
    excess = np.clip(np.sum(w[:, None] * np.sum(accel[use] - floor[None], axis=2), axis=0), 0.0, None)
    excess_sd = np.sqrt(np.sum((w[:, None, None] * accel_sd[use]) ** 2, axis=(0, 2)))
    linear = np.clip(np.sum(w[:, None] * (left[use] - floor.sum(axis=1)[None]), axis=0), 0.0, None)
    rotation = np.clip(excess - linear + BOUND_SIGMAS * excess_sd, 0.0, excess)
    return Split(edges, excess, rotation, excess_sd)


def not_turned(u: np.ndarray, rate: np.ndarray, rate_hz: float) -> np.ndarray:
    """(n, 3) the specific force u (n, 3) of a held pose less what the gyro's rate in its rows (n, 3, rad/s) explains:
    the tilt f x theta of gravity (with a gain fitted, which the gyro's own noise, integrated into theta, pulls
    towards none where it rules) and the acceleration alpha x r of a lever arm r from the point the hand turns about
    (r fitted: a hand's tremor turns the unit about the wrist, and the accelerometer reads that too)."""
    y = u - u.mean(axis=0)
    tilt = tilt_of(rate, u.mean(axis=0), rate_hz)
    alpha = np.gradient(rate - rate.mean(axis=0), 1.0 / rate_hz, axis=0)
    columns = np.concatenate([tilt[:, :, None], _cross_columns(alpha)], axis=2)      # (n, 3, 4)
    X = columns.reshape(-1, 4)
    coef, *_ = np.linalg.lstsq(X, y.reshape(-1), rcond=None)
    return y - (X @ coef).reshape(y.shape)


def _cross_columns(v: np.ndarray) -> np.ndarray:
    """(n, 3, 3): v x r = C r for r of three columns."""
    out = np.zeros(v.shape + (3,))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


def octaves(rate_hz: float) -> np.ndarray:
    """Band edges from LOWEST_HZ by octaves, the last band up to Nyquist."""
    nyquist = 0.5 * rate_hz
    edges = [LOWEST_HZ]
    while edges[-1] * 2 < nyquist:
        edges.append(edges[-1] * 2)
    return np.array(edges + [nyquist])


def band_variance(x: np.ndarray, rate_hz: float, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(B, 3) the variance of each column of x (n, 3) in each band (a Hann-windowed periodogram of the mean-removed
    stretch), and its standard deviation (each bin of a periodogram as uncertain as its value)."""
    x = x - x.mean(axis=0)
    n = len(x)
    window = np.hanning(n)
    spectrum = np.abs(np.fft.rfft(x * window[:, None], axis=0)) ** 2 / np.sum(window ** 2) * 2 / n
    freq = np.fft.rfftfreq(n, 1.0 / rate_hz)
    value, sd = np.zeros((len(edges) - 1, 3)), np.zeros((len(edges) - 1, 3))
    for b, (lo, hi) in enumerate(zip(edges[:-1], edges[1:])):
        sel = (freq >= lo) & (freq < hi) if b < len(edges) - 2 else (freq >= lo) & (freq <= hi)
        value[b] = spectrum[sel].sum(axis=0)
        sd[b] = np.sqrt(np.sum(spectrum[sel] ** 2, axis=0))
    return value, sd


def tilt_of(rate: np.ndarray, force: np.ndarray, rate_hz: float) -> np.ndarray:
    """(n, 3) what a rotation at `rate` (n, 3, rad/s, mean removed) does to a specific force `force` (3,): f x theta,
    theta its angle, integrated in the frequency domain (no content below LOWEST_HZ)."""
    w = rate - rate.mean(axis=0)
    spectrum = np.fft.rfft(w, axis=0)
    freq = np.fft.rfftfreq(len(w), 1.0 / rate_hz)
    keep = freq >= LOWEST_HZ
    angle_spectrum = np.where(keep[:, None], spectrum / (2j * np.pi * np.where(keep, freq, 1.0))[:, None], 0.0)
    angle = np.fft.irfft(angle_spectrum, n=len(w), axis=0)
    return np.cross(force, angle)
