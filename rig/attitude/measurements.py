"""What the filter is fed: gyro increments, the gravity direction and the horizontal field, with the
magnetometer samples that an indoor disturbance spoils rejected before they reach the update.

Navigation frame of the filter: magnetic ENU, `z` up (a still accelerometer measures `+G` along it),
`y` the horizontal component of the local field, `x = y x z` (east). It differs from the turntable's
world frame by a constant rotation (the declination, and any tilt of the table base), which the
validation estimates and removes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rig.attitude.noise import SensorNoise, gravity_direction_variance, heading_variance, process_variance
from rig.calibration.numerics.integrate import interval_rotvecs, quat_exp


@dataclass(frozen=True)
class Gates:
    """Tolerances beyond which a sample is not used (Yuan et al. use every sample; indoors that fails)."""

    accel_norm_fraction: float = 0.10   # | |a| - G | / G: the accelerometer sees more than gravity
    mag_norm_fraction: float = 0.05     # | |m| - M | / M: a disturbance changes the field's strength ...
    dip_deg: float = 3.0                # ... or its angle to gravity


@dataclass(frozen=True)
class StillDetector:
    """Zero-rate steps: where the gyro shows only noise, the fixture is taken as still.

    Why: integrating a still gyro adds its noise (and any residual bias) to the attitude every step, so
    on a hold a filter forgets its past measurements within ~0.3 s and its estimate wanders at the
    steady-state spread. A MEMS user knows the table stands still; over a still step the attitude is
    kept (no rotation) and the hold's gravity and field samples average down instead. A step is still
    when |w| stays below `n_sigma` gyro noise SDs (per axis) for `samples` steps up to it (causal); a
    velocity reversal passes zero in one or two steps, not ten.
    `process_scale` keeps part of the gyro-noise process variance on still steps: what the averaging
    cannot remove (the reference dip, calibration residuals, motion below the limit) are biases, and a
    filter with no process noise would claim 1/sqrt(N) and turn overconfident. 0.3 is measured: on the
    simulated rig it keeps ~96 % of the gain of 0.01 (benchmarks/bench_attitude.py, ten seeds), and the
    filter's 3-sigma still covers > 95 % of the errors on the synthetic motion (tests).
    """

    n_sigma: float = 4.0
    samples: int = 10
    process_scale: float = 0.3

    def __post_init__(self) -> None:
        if self.n_sigma <= 0 or self.samples < 1 or not 0.0 <= self.process_scale <= 1.0:
            raise ValueError(f"StillDetector needs n_sigma > 0, samples >= 1 and 0 <= process_scale <= 1, got {self}")

    def mask(self, gyro: np.ndarray, gyro_std: float) -> np.ndarray:
        """(n,) True on the steps taken as still: this and the `samples - 1` steps before below the limit."""
        low = np.linalg.norm(gyro, axis=1) < self.n_sigma * gyro_std
        run = np.concatenate([[0], np.cumsum(~low)])
        k = np.arange(len(low))
        start = np.maximum(k - self.samples + 1, 0)
        return low & (k >= self.samples - 1) & (run[k + 1] - run[start] == 0)


@dataclass
class Prepared:
    """Per-sample inputs of the kernel, as plain Python lists (the kernel loops in pure Python)."""

    dq: list              # (n,) tuples (w, x, y, z): gyro rotation over the step ending at sample k
    A: list               # (n,) 9-tuples: R(dq)^T row-major, maps the error vector across the step
    q_var: list           # (n,) process variance per axis (eq. 16)
    up: np.ndarray        # (n, 3) measured unit gravity direction, NaN where unusable
    north: np.ndarray     # (n, 3) measured unit horizontal field direction, NaN where unusable
    up_var: np.ndarray    # (n,) variance per axis of `up`
    heading_var: np.ndarray  # (n,)
    field_dir: np.ndarray  # (n, 3) measured unit field direction, NaN where unusable ('vector' mode)
    field_var: np.ndarray  # (n,) variance per axis of `field_dir`
    accel_ok: np.ndarray  # (n,) bool
    mag_ok: np.ndarray    # (n,) bool
    mag_present: int
    mag_rejected_norm: int
    mag_rejected_dip: int
    accel_rejected: int
    still: np.ndarray = None   # (n,) bool: zero-rate steps (StillDetector); all False without one


def fill_gyro(t: np.ndarray, gyro: np.ndarray) -> np.ndarray:
    """Gyro rates on every row: rows without a sample get the linear interpolation in time."""
    ok = np.isfinite(gyro).all(axis=1)
    if ok.sum() < 2:
        raise ValueError(f"the gyro has {int(ok.sum())} finite samples; the filter needs a rate on every step")
    if ok.all():
        return gyro
    return np.column_stack([np.interp(t, t[ok], gyro[ok, i]) for i in range(3)])


def gyro_increments(t: np.ndarray, gyro: np.ndarray) -> np.ndarray:
    """Rotation vectors of the steps (row k: from sample k-1 to k; row 0 zero), eqs. 7-8.

    The paper's first-order quaternion update is replaced by the rate-linear closed form of
    `rig.calibration.numerics.integrate` (trapezoid plus the coning term), exact for constant rates.
    """
    return np.vstack([np.zeros(3), interval_rotvecs(t, gyro)])


def transition_matrices(dq: np.ndarray) -> np.ndarray:
    """R(dq)^T for each step quaternion: the error rotation vector in the new body frame (eq. 13)."""
    w, x, y, z = dq.T
    R = np.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1).reshape(-1, 3, 3)
    return R.transpose(0, 2, 1)


def dip_of(accel: np.ndarray, mag: np.ndarray) -> np.ndarray:
    """Dip angle (rad, positive when the field points down) of each accel/mag pair."""
    a = accel / np.linalg.norm(accel, axis=-1, keepdims=True)
    m = mag / np.linalg.norm(mag, axis=-1, keepdims=True)
    return np.arcsin(np.clip(-np.sum(a * m, axis=-1), -1.0, 1.0))


def horizontal_direction(up: np.ndarray, mag: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit horizontal component of the field in the body frame, and its magnitude."""
    h = mag - np.sum(mag * up, axis=-1, keepdims=True) * up
    n = np.linalg.norm(h, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return h / n[..., None], n


def prepare(t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, mag: np.ndarray | None, noise: SensorNoise,
            gravity: float, field_uT: float, dip_rad: float, gates: Gates,
            still_detector: StillDetector | None = None) -> Prepared:
    """Everything that does not depend on the filter state, vectorised over the whole record.

    A magnetometer sample is used only beside a usable accelerometer sample: the dip gate and the
    heading both need the gravity direction.
    """
    t = np.asarray(t, dtype=float)
    gyro = fill_gyro(t, np.asarray(gyro, dtype=float))
    phi = gyro_increments(t, gyro)
    q_var = process_variance(noise.gyro_rad_s, np.concatenate([[0.0], np.diff(t)]))
    still = np.zeros(len(t), bool) if still_detector is None else still_detector.mask(gyro, noise.gyro_rad_s)
    phi[still] = 0.0
    q_var[still] *= 0.0 if still_detector is None else still_detector.process_scale
    dq = quat_exp(phi)
    A = transition_matrices(dq).reshape(-1, 9)

    accel = np.asarray(accel, dtype=float)
    a_norm = np.linalg.norm(accel, axis=1)
    finite_a = np.isfinite(a_norm) & (a_norm > 0)
    accel_ok = finite_a & (np.abs(a_norm - gravity) <= gates.accel_norm_fraction * gravity)
    up = np.where(accel_ok[:, None], accel / np.where(finite_a, a_norm, 1.0)[:, None], np.nan)
    up_var = gravity_direction_variance(noise.accel_mps2, np.where(finite_a, a_norm, gravity))

    n = len(t)
    north = np.full((n, 3), np.nan)
    heading_var = np.full(n, np.nan)
    field_dir = np.full((n, 3), np.nan)
    field_var = np.full(n, np.nan)
    mag_ok = np.zeros(n, bool)
    present = rej_norm = rej_dip = 0
    if mag is not None:
        mag = np.asarray(mag, dtype=float)
        m_norm = np.linalg.norm(mag, axis=1)
        present_mask = np.isfinite(m_norm) & (m_norm > 0)
        norm_bad = present_mask & (np.abs(m_norm - field_uT) > gates.mag_norm_fraction * field_uT)
        with np.errstate(invalid="ignore"):
            dip = dip_of(np.where(finite_a[:, None], accel, np.nan), mag)
        dip_bad = present_mask & ~norm_bad & finite_a & (np.abs(dip - dip_rad) > math.radians(gates.dip_deg))
        mag_ok = present_mask & accel_ok & ~norm_bad & ~dip_bad
        h, h_norm = horizontal_direction(np.where(accel_ok[:, None], up, 0.0),
                                         np.where(present_mask[:, None], mag, 0.0))
        north = np.where(mag_ok[:, None], h, np.nan)
        heading_var = heading_variance(noise.mag_uT, np.where(mag_ok, h_norm, 1.0), noise.accel_mps2, gravity, dip_rad)
        present, rej_norm, rej_dip = int(present_mask.sum()), int(norm_bad.sum()), int(dip_bad.sum())
        safe_norm = np.where(mag_ok, m_norm, 1.0)
        field_dir = np.where(mag_ok[:, None], mag / safe_norm[:, None], np.nan)
        field_var = (noise.mag_uT / safe_norm) ** 2
    return Prepared(dq=list(map(tuple, dq.tolist())), A=list(map(tuple, A.tolist())), q_var=q_var.tolist(),
                    up=up, north=north, up_var=up_var, heading_var=heading_var,
                    field_dir=field_dir, field_var=field_var, accel_ok=accel_ok, mag_ok=mag_ok,
                    mag_present=present, mag_rejected_norm=rej_norm, mag_rejected_dip=rej_dip,
                    accel_rejected=int((finite_a & ~accel_ok).sum()), still=still)


def field_in_navigation(dip_rad: float) -> tuple[float, float, float]:
    """Unit field direction in the navigation frame (magnetic ENU): north and down by the dip."""
    return (0.0, math.cos(dip_rad), -math.sin(dip_rad))


def triad(up: np.ndarray, field: np.ndarray) -> np.ndarray:
    """Fixture -> navigation matrix from one gravity direction and one field vector (body frame).

    Rows of R are the navigation axes in the body frame: R^T e_z = up, R^T e_y = horizontal field.
    """
    z = up / np.linalg.norm(up)
    y = field - (field @ z) * z
    y = y / np.linalg.norm(y)
    return np.vstack([np.cross(y, z), y, z])


def tilt_only(up: np.ndarray) -> np.ndarray:
    """Fixture -> navigation matrix from gravity alone (heading arbitrary): for sessions without a magnetometer."""
    z = up / np.linalg.norm(up)
    ref = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    return triad(z, ref)
