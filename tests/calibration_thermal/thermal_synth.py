"""Simulated units whose B and H move with die temperature, calibrated at each step of a thermal session.

Curves are polynomials in x = (T - 25 C) / 35 C (so x spans about [-1, 1] over -10..60 C):
    B(T) = B0 + b1 x + b2 x^2 + b3 x^3,      H(T) = (I + D(x)) H0,
D diagonal: the scale's drift (cubic, a few hundred ppm over the range); off-diagonal: the cross-axis drift
(linear, tens of microradians). The accelerometer at each step is calibrated by the rig's own joint estimator
(`calibrate_joint`) on hold means simulated at 12 poses (2 s holds at 100 Hz, ~1 mg sample noise), so each
step's noise and its stated covariance are those the estimator gives. The gyroscope's move-based estimate is
stood in for by a Gaussian draw: B from 24 s of hold data at 5 mdps/sqrt(Hz), H per element 40 ppm of the
scale (a short schedule's), and the same deviations stated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.thermal import ThermalStep
from rig.calibration.thermal.joint import ThermalHolds
from rig.calibration.turntable.joint import calibrate_joint

G = 9.80665
ACCEL_COUNTS_PER_MPS2 = 8192 / G          # +-4 g, 16 bit
GYRO_COUNTS_PER_RADS = 65.5 * 180 / np.pi  # +-500 dps, 16 bit
MG = G / 1000
MDPS = np.pi / 180 / 1000
STEPS_C = np.linspace(-10.0, 65.0, 7)
HOLDS, HOLD_SAMPLES, ACCEL_SAMPLE_STD_MG = 12, 200, 1.0
GYRO_B_STD_MDPS, GYRO_H_STD_PPM = 5.0 / np.sqrt(24.0), 40.0
TEMP_STD_C = 0.05


def x_of(temp_c) -> np.ndarray:
    return (np.asarray(temp_c, dtype=float) - 25.0) / 35.0


@dataclass
class ThermalUnit:
    sensor: str
    B0: np.ndarray            # counts
    b: np.ndarray             # (3 powers, 3 axes) counts
    H0: np.ndarray
    scale: np.ndarray         # (3 powers, 3 axes) relative
    cross: np.ndarray         # (3, 3) relative per unit x, off-diagonal

    def B(self, temp_c: float) -> np.ndarray:
        x = float(x_of(temp_c))
        return self.B0 + np.array([x, x ** 2, x ** 3]) @ self.b

    def H(self, temp_c: float) -> np.ndarray:
        x = float(x_of(temp_c))
        D = np.diag(np.array([x, x ** 2, x ** 3]) @ self.scale) + x * self.cross
        return (np.eye(3) + D) @ self.H0

    def true_orders(self) -> dict[str, list[int]]:
        """The orders of the true curves (what a model knowing them would fit)."""
        def order(coeffs: np.ndarray) -> int:
            nz = np.flatnonzero(np.any(coeffs != 0, axis=1))
            return int(nz[-1] + 1) if nz.size else 0
        b_orders = [order(self.b[:, [i]]) for i in range(3)]
        s = order(self.scale)
        h = max(s, 1 if np.any(self.cross) else 0)
        return {"B": b_orders, "H": [h] * 9}


def make_unit(sensor: str, rng: np.random.Generator, shape: str = "cubic") -> ThermalUnit:
    """A unit with `shape` curves: "cubic" (bias and scale cubic-ish), "linear" (bias linear, scale linear) or
    "flat" (nothing moves with temperature)."""
    if sensor == "accel":
        k, b_unit = ACCEL_COUNTS_PER_MPS2, MG * ACCEL_COUNTS_PER_MPS2          # counts per mg
        b_size = np.array([1.5, 0.6, 1.0])                                    # mg per power of x
        B0 = rng.uniform(-50, 50, 3) * b_unit
    else:
        k, b_unit = GYRO_COUNTS_PER_RADS, MDPS * GYRO_COUNTS_PER_RADS         # counts per mdps
        b_size = np.array([700.0, 250.0, 350.0])                              # mdps: ~20 mdps/C
        B0 = rng.uniform(-1000, 1000, 3) * b_unit
    M = np.eye(3) + 0.01 * rng.standard_normal((3, 3))
    Q = Rotation.from_rotvec(np.radians(2.0) * rng.standard_normal(3)).as_matrix()
    H0 = np.linalg.inv(k * M) @ Q.T
    signs = rng.choice([-1.0, 1.0], (3, 3))
    b = b_size[:, None] * rng.uniform(0.7, 1.3, (3, 3)) * signs * b_unit
    scale = np.array([150e-6, 60e-6, 100e-6])[:, None] * rng.uniform(0.7, 1.3, (3, 3)) * rng.choice([-1.0, 1.0], (3, 3))
    cross = 30e-6 * rng.standard_normal((3, 3))
    np.fill_diagonal(cross, 0.0)
    if shape == "linear":
        b[1:] = 0.0
        scale[1:] = 0.0
    elif shape == "flat":
        b[:] = 0.0
        scale[:] = 0.0
        cross[:] = 0.0
    return ThermalUnit(sensor, B0, b, H0, scale, cross)


def gyro_step_calibration(unit: ThermalUnit, temp_c: float, rng: np.random.Generator) -> TriadCalibration:
    """The gyroscope's calibration at `temp_c`: the Gaussian stand-in of the module docstring."""
    B, H = unit.B(temp_c), unit.H(temp_c)
    b_std = np.full(3, GYRO_B_STD_MDPS * MDPS * GYRO_COUNTS_PER_RADS)
    h_std = np.full((3, 3), GYRO_H_STD_PPM * 1e-6 * float(np.mean(np.abs(np.diag(H)))))
    return TriadCalibration(B=B + b_std * rng.standard_normal(3), H=H + h_std * rng.standard_normal((3, 3)),
                            method="simulated", B_std=b_std, H_std=h_std, B_cov=np.diag(b_std ** 2),
                            H_cov=np.diag(h_std.reshape(9) ** 2))


def steps_from_holds(holds: list[ThermalHolds]) -> list[ThermalStep]:
    """Each step's hold means calibrated by the rig's joint estimator."""
    return [ThermalStep(temp_c=h.temp_c, calibration=calibrate_joint(h.y_means, h.R, G, y_std=h.y_std,
                                                                     counts=h.counts), temp_std_c=h.temp_std_c)
            for h in holds]


def thermal_steps(unit: ThermalUnit, rng: np.random.Generator, temps_c=STEPS_C) -> list[ThermalStep]:
    """One calibration per temperature step (the accelerometer's from its hold means, the same 12-pose schedule
    at each); each step's die temperature is read with TEMP_STD_C of error, and says so."""
    if unit.sensor == "accel":
        return steps_from_holds(accel_holds(unit, rng, temps_c))
    return [ThermalStep(temp_c=float(t) + TEMP_STD_C * rng.standard_normal(),
                        calibration=gyro_step_calibration(unit, float(t), rng), temp_std_c=TEMP_STD_C)
            for t in temps_c]


def held_out_temps(temps_c=STEPS_C) -> np.ndarray:
    """The temperatures halfway between adjacent steps."""
    t = np.sort(np.asarray(temps_c, dtype=float))
    return 0.5 * (t[1:] + t[:-1])


def errors(unit: ThermalUnit, B_est: np.ndarray, H_est: np.ndarray, temp_c: float) -> dict[str, float]:
    """At one temperature: the bias error in the calibrated unit (mg or mdps, norm over the axes), the scale
    error (ppm, norm of the diagonal of H_est H_true^-1 - I), and the calibrated-output error at full reference
    input (1 g or 100 dps along each axis, worst of the six, in mg or mdps): what a user sees."""
    H = unit.H(temp_c)
    small = MG if unit.sensor == "accel" else MDPS
    ref = G if unit.sensor == "accel" else 100 * np.pi / 180
    bias = np.linalg.norm(H @ (B_est - unit.B(temp_c))) / small
    rel = H_est @ np.linalg.inv(H) - np.eye(3)
    scale = np.linalg.norm(np.diag(rel)) * 1e6
    worst = 0.0
    for u in np.vstack([np.eye(3), -np.eye(3)]) * ref:
        y = np.linalg.solve(H, u) + unit.B(temp_c)
        worst = max(worst, float(np.linalg.norm(H_est @ (y - B_est) - u)))
    return {"bias": float(bias), "scale_ppm": float(scale), "output": worst / small}


def accel_holds(unit: ThermalUnit, rng: np.random.Generator, temps_c=STEPS_C) -> list[ThermalHolds]:
    """The accelerometer's hold means at each step (the same 12-pose schedule at each), as the joint fit takes
    them; the die temperature read with TEMP_STD_C of error."""
    R = Rotation.random(HOLDS, random_state=rng).as_matrix()
    sample_std = ACCEL_SAMPLE_STD_MG * MG * ACCEL_COUNTS_PER_MPS2
    out = []
    for t in temps_c:
        x = np.einsum("kji,j->ki", R, np.array([0.0, 0.0, G]))
        y = x @ np.linalg.inv(unit.H(float(t))).T + unit.B(float(t))
        y = y + sample_std / np.sqrt(HOLD_SAMPLES) * rng.standard_normal(x.shape)
        out.append(ThermalHolds(temp_c=float(t) + TEMP_STD_C * rng.standard_normal(), y_means=y, R=R,
                                y_std=np.full(y.shape, sample_std), counts=np.full(len(y), HOLD_SAMPLES),
                                temp_std_c=TEMP_STD_C))
    return out
