"""Physical constants the datasheets' scales are written in."""

STANDARD_GRAVITY = 9.80665   # m/s^2 per g (3rd CGPM, 1901): the "g" of every accelerometer datasheet
