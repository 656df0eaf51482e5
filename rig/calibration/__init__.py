"""Calibration math: pure functions on arrays (Zhang, IEEE TIE 2015, and beyond)."""
