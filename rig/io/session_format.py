"""The names and limits of the interchange layout `imu-session-csv/1` (docs/reference/session-csv.md).

The reader, the meta.json check, the column checks and the writer all follow the same spec; its file names,
column names, allowed values and plausible ranges live here, once, so that none of those modules has to
import another to learn them.
"""

FORMAT = "imu-session-csv/1"
META_FILE = "meta.json"
SAMPLES_FILE = "samples.csv"
QUAT_COLUMNS = ("qw", "qx", "qy", "qz")
REQUIRED_COLUMNS = ("t", "phase", "step", *QUAT_COLUMNS)
TABLE_COLUMNS = ("table_outer_deg", "table_inner_deg")
PHASES = ("hold", "move")
# A quaternion written with 6 significant digits is within ~1e-6 of unit norm; 1e-3 lets
# tracker output through and still catches a swapped or missing component.
QUAT_NORM_TOL = 1e-3
REFERENCES = ("table", "none")
UNITS = {"accel": ("counts", "m/s^2"), "gyro": ("counts", "deg/s", "rad/s"), "mag": ("counts", "uT")}
SEGMENT_KINDS = ("static", "rotation")
SENSOR_AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
# Plausible ranges: a value beyond them is a broken cell, not a measurement (epoch seconds up to the year 2286;
# a temperature no electronics survive; 100 turns of an axis; counts of a 32-bit converter; 1000 g, 10^5 deg/s,
# 10^5 uT in physical units).
T_LIMIT_S = 1e10
TEMP_RANGE_C = (-100.0, 250.0)
SUPPLY_RANGE_V = (0.0, 100.0)
ANGLE_LIMIT_DEG = 36000.0
COUNT_LIMIT = 2.0 ** 32
RAW_LIMITS = {"m/s^2": 1e4, "deg/s": 1e5, "rad/s": 2e3, "uT": 1e5}
# Rows this many times further apart (or closer) than sample_rate_hz says: t is not in seconds (ms: 1000 times).
# Not a tighter bound: rows of several sensors at different rates may come faster than the rate meta.json gives.
RATE_MISMATCH = 100.0
