"""rig: acquisition and calibration rig controller for miniature inertial and magnetic sensor units."""

__version__ = "0.1.0"
