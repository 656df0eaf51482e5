"""Attitude from calibrated gyro, accelerometer and magnetometer: the quaternion UKF of Yuan et al.
(Sensors 2015) made singularity-free, the peers from `ahrs`, and the comparison with a turntable
reference (the paper's Table III). See `ukf.py` for the filter, `evaluate.py` for sessions,
`smoother.py` for the non-causal bound."""

from rig.attitude.compare import AXES, Comparison, compare, error_rpy_deg, estimate_alignment, rpy_deg
from rig.attitude.measurements import Gates, StillDetector
from rig.attitude.noise import SensorNoise
from rig.attitude.smoother import smooth_attitude
from rig.attitude.ukf import AttitudeEstimate, UKFSettings, estimate_attitude

__all__ = ["AXES", "AttitudeEstimate", "Comparison", "Gates", "SensorNoise", "StillDetector", "UKFSettings", "compare",
           "error_rpy_deg", "estimate_alignment", "estimate_attitude", "rpy_deg", "smooth_attitude"]
