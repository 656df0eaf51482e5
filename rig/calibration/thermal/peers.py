"""The autopilots' offset-only temperature corrections, reproduced from their published methods for comparison.

Both fit a third-order polynomial of each axis's offset against die temperature, unweighted, and correct the
offset alone: the scale and cross-axis terms stay those of the one calibration made at one temperature.

PX4 (PX4-Autopilot, `Tools/process_sensor_caldata.py`, commit 00f5c319563d03d2ce482dbd1b53dff25b5a7f34, and the
`TC_G*`/`TC_A*` parameters): `TREF = (TMIN + TMAX) / 2` from the coldest and hottest logged temperature, each
axis's raw reading median-filtered, averaged in bins of temperature, and fitted by `polyfit(T - TREF, x, 3)`
(coefficients `X0..X3`); on board the correction is evaluated with the temperature clamped to [TMIN, TMAX].
The normal calibration made afterwards at one temperature T_cal absorbs what the polynomial leaves there, so
the offset the unit uses at T is `B_cal + p(T) - p(T_cal)`.

ArduPilot (ArduPilot, `libraries/AP_InertialSensor/AP_InertialSensor_tempcal.cpp`, commit
025810d325bad2593ff100bc50a2bc7e9d300755, `INS_TCALn_*`): while the board warms it averages samples into a bin
until at least 100 samples and a 0.5 C rise, tags the bin with the mean of its start and end temperature, takes
the accelerometer's first bin as the zero baseline, and accumulates each bin into a least-squares cubic about
a fixed reference of 35 C; the constant is dropped and the 1st..3rd-order coefficients kept (`ACC1..3`,
`GYR1..3`), `TMIN` the start and `TMAX` the end temperature. The correction at T is
`v - p(T - 35) + p(T_cal - 35)`, T and T_cal clamped to [TMIN, TMAX], T_cal the temperature of the normal
calibration.

On a stepped session each step is one bin for both (its holds span no 0.5 C rise; PX4's bins of temperature
collect each step's samples into one or a few bins at the step's temperature), so the step offsets B_k at T_k are
what both fit. The two then differ only in reference temperature, constant and clamping: on temperatures inside
the fitted range their offsets coincide (a cubic least-squares fit does not depend on where its origin is).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ARDUPILOT_REFERENCE_C = 35.0
ARDUPILOT_MIN_SAMPLES = 100
ARDUPILOT_MIN_RISE_C = 0.5


@dataclass
class OffsetPolynomial:
    """Offset(T) = B_cal + p(clamp(T) - reference) - p(clamp(T_cal) - reference) per axis; H stays H_cal."""

    name: str
    reference_c: float
    tmin_c: float
    tmax_c: float
    coefficients: np.ndarray        # (3 axes, 4): constant first
    B_cal: np.ndarray
    H_cal: np.ndarray
    cal_temp_c: float

    def _p(self, temp_c: float) -> np.ndarray:
        dt = float(np.clip(temp_c, self.tmin_c, self.tmax_c)) - self.reference_c
        return self.coefficients @ (dt ** np.arange(4))

    def B_at(self, temp_c: float) -> np.ndarray:
        return self.B_cal + self._p(temp_c) - self._p(self.cal_temp_c)

    def H_at(self, temp_c: float) -> np.ndarray:
        return self.H_cal


def px4_offset_fit(temps_c: np.ndarray, offsets: np.ndarray, B_cal: np.ndarray, H_cal: np.ndarray,
                   cal_temp_c: float) -> OffsetPolynomial:
    """PX4's fit (module docstring) of per-bin offsets (n, 3) at temperatures (n,)."""
    T = np.asarray(temps_c, dtype=float)
    tmin, tmax = float(T.min()), float(T.max())
    tref = 0.5 * (tmin + tmax)
    coeffs = np.stack([np.polynomial.polynomial.polyfit(T - tref, offsets[:, i], 3) for i in range(3)])
    return OffsetPolynomial("px4", tref, tmin, tmax, coeffs, np.asarray(B_cal, float), np.asarray(H_cal, float),
                            float(cal_temp_c))


def ardupilot_bins(temps_c: np.ndarray, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ArduPilot's accumulation of a sample stream (in time order) into bins: a bin closes once it holds at least
    100 samples and the temperature has risen 0.5 C since the last bin closed; its temperature is the mean of
    that temperature and the closing one. Returns (bin temperatures, bin means)."""
    temps, means = [], []
    last = float(temps_c[0])
    total, count = np.zeros(samples.shape[1]), 0
    for t, y in zip(np.asarray(temps_c, float), np.asarray(samples, float)):
        total += y
        count += 1
        if count < ARDUPILOT_MIN_SAMPLES or t - last < ARDUPILOT_MIN_RISE_C:
            continue
        temps.append(0.5 * (t + last))
        means.append(total / count)
        total, count, last = np.zeros(samples.shape[1]), 0, float(t)
    return np.asarray(temps), np.asarray(means).reshape(-1, samples.shape[1])


def ardupilot_offset_fit(temps_c: np.ndarray, offsets: np.ndarray, B_cal: np.ndarray, H_cal: np.ndarray,
                         cal_temp_c: float) -> OffsetPolynomial:
    """ArduPilot's fit (module docstring) of per-bin offsets (n, 3) at bin temperatures (n,), coldest first."""
    T = np.asarray(temps_c, dtype=float)
    baseline = offsets[np.argmin(T)]
    coeffs = np.stack([np.polynomial.polynomial.polyfit(T - ARDUPILOT_REFERENCE_C, offsets[:, i] - baseline[i], 3)
                       for i in range(3)])
    coeffs[:, 0] = 0.0
    return OffsetPolynomial("ardupilot", ARDUPILOT_REFERENCE_C, float(T.min()), float(T.max()), coeffs,
                            np.asarray(B_cal, float), np.asarray(H_cal, float), float(cal_temp_c))
