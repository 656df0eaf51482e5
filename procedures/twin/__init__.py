"""The twin: a recording replayed in a simulated world with the calibration made of it, its statistics set beside the
replicas', and the causes the linear model misses searched for (`rig discrepancy`)."""
