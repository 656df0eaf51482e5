"""Units of the rig: the one standard gravity (from the drivers, which scale by it) and each sensor's units.

`SENSOR_UNITS` is what a calibrated sensor reads (`u = H (y - B)`, calibration-json.md); `REPORT_UNITS` what the
effects vocabulary reports magnitudes in (effects.md: gyro rates in deg/s), with the factor from the first.
"""

import math

from drivers.units import STANDARD_GRAVITY

DEG = math.pi / 180.0
SENSOR_UNITS = {"accel": "m/s^2", "gyro": "rad/s", "mag": "uT"}
REPORT_UNITS = {"accel": ("m/s^2", 1.0), "gyro": ("deg/s", DEG), "mag": ("uT", 1.0)}   # (unit, calibrated per unit)

__all__ = ["STANDARD_GRAVITY", "DEG", "SENSOR_UNITS", "REPORT_UNITS"]
