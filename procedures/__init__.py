"""Procedures compose devices (through small typed protocols) into calibration sessions and trials."""
