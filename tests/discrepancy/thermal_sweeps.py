"""Simulated thermal sessions swept up then down, with hysteresis and thermal lag injected, for the thermal causes.

The unit and its per-step calibrations are those of tests/calibration_thermal/thermal_synth.py (imported: the
accelerometer calibrated by the rig's joint estimator from simulated hold means, the gyroscope by its Gaussian
stand-in with stated deviations). The session: set points from -10 to 65 C up (7 steps), then back down through
the same set points (6 more); each step's die temperature read with thermal_synth.TEMP_STD_C of error and its
rate during the holds drawn per step (a soaked session: small, a ramped one: 0.2 to 2 C/min), positive going up.
Injected, in the truth the calibrations see:

    B(T) = B_unit(T - r tau) + s h_bias,     H(T) = (I + s diag(h_scale)) H_unit(T - r tau),

s = +1 up, -1 down, h_bias given in the calibrated frame (mdps, mg) and turned into counts by H.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rig.calibration.thermal import ThermalStep
from rig.discrepancy.thermal import SweptStep
from tests.calibration_thermal.thermal_synth import (MDPS, MG, STEPS_C, TEMP_STD_C, ThermalUnit, accel_holds,
                                                     gyro_step_calibration, make_unit, steps_from_holds)

UP_C = STEPS_C
DOWN_C = STEPS_C[::-1][1:]
SOAKED_RATE_C_PER_MIN = (0.01, 0.08)
RAMPED_RATE_C_PER_MIN = (0.2, 2.0)


@dataclass
class Injected:
    """What a session hides: the bias half-width per axis (mdps or mg, calibrated frame), the scales' (relative)
    and the lag (s)."""

    bias: np.ndarray
    scale: np.ndarray
    tau_s: float

    @property
    def bias_magnitude(self) -> float:
        return float(np.max(np.abs(self.bias)))


@dataclass
class _StepTruth:
    """The unit as one step's calibration sees it (module docstring), with thermal_synth's B(T), H(T) interface."""

    unit: ThermalUnit
    sign: float
    shift_c: float
    bias_counts: np.ndarray
    scale: np.ndarray

    def B(self, temp_c: float) -> np.ndarray:
        return self.unit.B(temp_c - self.shift_c) + self.sign * self.bias_counts

    def H(self, temp_c: float) -> np.ndarray:
        return (np.eye(3) + self.sign * np.diag(self.scale)) @ self.unit.H(temp_c - self.shift_c)


def injected(rng: np.random.Generator, bias: float = 0.0, scale: float = 0.0, tau_s: float = 0.0) -> Injected:
    """A hidden hysteresis whose largest axis is `bias` (the others 30-100 % of it, random signs) and whose scales'
    largest is `scale`, and a lag `tau_s`."""
    def vector(m: float) -> np.ndarray:
        v = m * rng.uniform(0.3, 1.0, 3) * rng.choice([-1.0, 1.0], 3)
        v[rng.integers(3)] = m * rng.choice([-1.0, 1.0])
        return v
    return Injected(vector(bias), vector(scale), float(tau_s))


def rates(rng: np.random.Generator, ramped: bool, steps: int) -> np.ndarray:
    lo, hi = RAMPED_RATE_C_PER_MIN if ramped else SOAKED_RATE_C_PER_MIN
    return rng.uniform(lo, hi, steps)


def swept_session(sensor: str, rng: np.random.Generator, hidden: Injected, *, ramped: bool = True,
                  shape: str = "cubic", rate_c_per_min: np.ndarray | None = None, air_lead_c: float = 0.0
                  ) -> list[SweptStep]:
    """One thermal session's steps (module docstring); `rate_c_per_min` (magnitudes, one per step) in place of the
    drawn ones; `air_lead_c`: how far the chamber air runs ahead of the die in the sweep's direction."""
    unit = make_unit(sensor, rng, shape)
    temps = np.concatenate([UP_C, DOWN_C])
    signs = np.concatenate([np.ones(len(UP_C)), -np.ones(len(DOWN_C))])
    size = np.abs(rate_c_per_min) if rate_c_per_min is not None else rates(rng, ramped, len(temps))
    small = MG if sensor == "accel" else MDPS
    out = []
    for t, s, r in zip(temps, signs, size * signs):
        H = unit.H(float(t))
        truth = _StepTruth(unit, float(s), float(r) * hidden.tau_s / 60.0,
                           np.linalg.solve(H, hidden.bias * small), hidden.scale)
        if sensor == "accel":
            step = steps_from_holds(accel_holds(truth, rng, [float(t)]))[0]
        else:
            step = ThermalStep(float(t) + TEMP_STD_C * rng.standard_normal(),
                               gyro_step_calibration(truth, float(t), rng), TEMP_STD_C)
        out.append(SweptStep(step, "up" if s > 0 else "down", float(r), float(t) + s * air_lead_c))
    return out
