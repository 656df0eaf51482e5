"""Files in and out: the interchange session layout, imu_tk ASCII, the calibration JSON."""
