"""Calibration across temperature: B(T) and H(T) fitted from one calibration per temperature step."""

from rig.calibration.thermal.model import (FORMAT_VERSION, TemperatureOutOfRange, ThermalModel, ThermalStep,
                                           fit_thermal_model)

__all__ = ["FORMAT_VERSION", "TemperatureOutOfRange", "ThermalModel", "ThermalStep", "fit_thermal_model"]
