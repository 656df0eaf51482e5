"""imu_tk's ASCII files (one per sensor, `timestamp x y z`) as a recording without a turntable.

imu_tk samples its sensors together, so the files must share their time stamps row for row; nothing is known
of the intervals (static intervals are found from the data), so the session has no segments. imu_tk's own files
hold raw counts; a logger that writes the same layout in physical units (m/s^2, rad/s) says so with `units`, as
every importer does.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.imu_tk import read_imu_tk_lines
from rig.io.recording import STANDARD_GRAVITY, check_counts, recording_session, to_session_units
from rig.session_data import SessionData

STAMP_TOLERANCE_S = 1e-6


def import_imu_tk(files: dict[str, str | os.PathLike], *, units: dict[str, str] | None = None,
                  gravity: float = STANDARD_GRAVITY, field_uT: float | None = None,
                  initial_rest_s: float | None = None) -> SessionData:
    """`files`: sensor ('accel', 'gyro', 'mag') -> its imu_tk file; `units`: sensor -> the unit its file is in
    (`rig.io.recording.IMPORT_UNITS`), raw counts where not named. Without `field_uT` a magnetometer is calibrated to
    the field magnitude its own samples show."""
    t, raw, where = None, {}, {}
    first = None
    for sensor, path in files.items():
        ts, xyz, lines = read_imu_tk_lines(path)
        if t is None:
            t, first = ts, Path(path)
        elif len(ts) != len(t) or not np.allclose(ts, t, rtol=0, atol=STAMP_TOLERANCE_S):
            row = _first_difference(t, ts)
            raise SessionFormatError(path, f"time stamps differ from {first}'s ({len(ts)} rows against {len(t)}; "
                                     "imu_tk files of one recording are sampled together)", int(lines[min(row, len(lines) - 1)]),
                                     "timestamp")
        raw[sensor] = xyz
        where[sensor] = (str(path), ["x", "y", "z"], lines)
    units = {s: (units or {}).get(s, "counts") for s in raw}
    check_counts(raw, units, where)
    raw, kept = to_session_units(raw, units)
    rate = float(1.0 / np.median(np.diff(t))) if len(t) > 1 else None
    return recording_session(t, raw, units=kept, gravity=gravity, field_uT=field_uT, sample_rate_hz=rate,
                             source=str(first), initial_rest_s=initial_rest_s,
                             imported={"format": "imu_tk", "files": {s: str(p) for s, p in files.items()},
                                       "units": units})


def _first_difference(a: np.ndarray, b: np.ndarray) -> int:
    n = min(len(a), len(b))
    diff = np.flatnonzero(np.abs(a[:n] - b[:n]) > STAMP_TOLERANCE_S)
    return int(diff[0]) if diff.size else n
