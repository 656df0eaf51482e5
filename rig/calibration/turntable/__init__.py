"""Fits from turntable sessions: the accelerometer and magnetometer (two-step, joint), the gyro from the table's known rotations, the lever arm, observability and the Cramer-Rao bound."""
