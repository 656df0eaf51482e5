"""Apply a calibration at the die temperature of each row, where it carries a temperature model.

A calibration read from calibration.json keeps its sensor's `temperature_model` object in `extra` (the reader
validated it). With a temperature per row, the rows are calibrated by `H(T) (y - B(T))` and a row whose
temperature lies outside the model's range refuses the whole application, by name (`TemperatureOutOfRange`,
exit 2): a calibration is never extrapolated. A row without a temperature reading (NaN) has no calibrated
value (NaN), as a row without a sample has none. Without a model, or without temperatures, the constant
calibration `H (y - B)` applies, as it always did.
"""

from __future__ import annotations

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.calibration.thermal.model import ThermalModel


def apply_with_temperature(sensor: str, cal: TriadCalibration, y: np.ndarray, temp_c: np.ndarray | None,
                           specific_force: np.ndarray | None = None) -> np.ndarray:
    """Calibrated rows (n, 3) of raw rows y at temperatures temp_c (n,) (module docstring); the gyroscope's
    g-sensitivity, where the calibration has one and the specific force is given, comes off first."""
    model_doc = cal.extra.get("temperature_model")
    if model_doc is None or temp_c is None:
        return cal.apply(y, specific_force)
    model = ThermalModel.from_json_dict(sensor, model_doc)
    y = np.asarray(y, dtype=float)
    if cal.g_sensitivity is not None and specific_force is not None:
        y = y - cal.g_sensitivity.raw_rate(specific_force)
    t = np.broadcast_to(np.asarray(temp_c, dtype=float), (y.shape[0],))
    known = np.isfinite(t)
    u = np.full(y.shape, np.nan)
    if known.any():
        u[known] = model.apply_at(y[known], t[known])
    return u
