"""Noise of the calibrated sensors and what it becomes in the filter (Yuan et al. 2015, eqs. 16-22).

The paper's text was not available here; the equations are reconstructed from its description (and the
equation numbers of the project brief). The filter's state is the error rotation vector around the mean
quaternion, so the paper's quaternion-space covariances become their rotation-vector counterparts:

* eq. 16, process noise: the gyro noise `sigma_g` integrated over one step gives an error rotation of
  variance `(sigma_g dt)^2` per axis (the quaternion form `(dt/2)^2 Xi Sigma_g Xi^T` mapped to the tangent space).
* eqs. 17-22, measurement noise: the paper propagates accelerometer and magnetometer noise through its
  roll/pitch/heading formulas. Our measurement is singularity-free (the unit gravity direction and the
  heading of the horizontal field, see `ukf.py`); the same propagation gives `(sigma_a / |a|)^2` per axis
  for the unit gravity direction and, for the heading, the horizontal-field noise `(sigma_m / M_h)^2` plus
  the tilt error carried into the tilt-compensated field, `tan(dip)^2 (sigma_a / g)^2`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SensorNoise:
    """Per-sample white-noise standard deviations of the calibrated signals, per axis."""

    gyro_rad_s: float
    accel_mps2: float
    mag_uT: float

    @classmethod
    def from_static(cls, gyro: np.ndarray, accel: np.ndarray, mag: np.ndarray | None) -> "SensorNoise":
        """Estimate from calibrated samples taken while the fixture was still (NaN rows ignored).

        Why from data: the noise the filter sees includes quantisation and the chips' range settings,
        which a datasheet figure does not know.
        """
        def axis_std(x) -> float:
            if x is None:
                return float("nan")
            x = np.asarray(x, dtype=float)
            x = x[np.isfinite(x).all(axis=1)]
            if len(x) < 3:
                raise ValueError(f"need at least 3 static samples to estimate noise, got {len(x)}")
            return float(np.sqrt(np.mean(np.var(x, axis=0, ddof=1))))

        return cls(axis_std(gyro), axis_std(accel), axis_std(mag) if mag is not None else float("nan"))

    def floored(self, gyro_rad_s: float = 0.0, accel_mps2: float = 0.0, mag_uT: float = 0.0) -> "SensorNoise":
        return SensorNoise(max(self.gyro_rad_s, gyro_rad_s), max(self.accel_mps2, accel_mps2),
                           max(self.mag_uT, mag_uT))


def process_variance(gyro_std: float, dt: np.ndarray) -> np.ndarray:
    """Eq. 16 in tangent-space form: variance of the error rotation per axis added over each step."""
    return (gyro_std * np.asarray(dt, dtype=float)) ** 2


def gravity_direction_variance(accel_std: float, accel_norm: np.ndarray) -> np.ndarray:
    """Eqs. 17-19 counterpart: variance per axis of the measured unit gravity direction."""
    return (accel_std / np.asarray(accel_norm, dtype=float)) ** 2


def heading_variance(mag_std: float, horizontal_field: np.ndarray, accel_std: float, gravity: float,
                     dip_rad: float) -> np.ndarray:
    """Eqs. 20-22 counterpart: variance of the tilt-compensated heading, rad^2.

    A tilt error eps about the horizontal field direction moves the vertical field component
    `M sin(dip)` into the horizontal plane, a heading error `eps tan(dip)`.
    """
    tilt_var = (accel_std / gravity) ** 2
    return (mag_std / np.asarray(horizontal_field, dtype=float)) ** 2 + math.tan(dip_rad) ** 2 * tilt_var
