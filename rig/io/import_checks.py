"""What an importer checks of the numbers it read before it writes a session: every sample within the plausible
range of the interchange layout (`rig.io.session_format`: a 1e308 cell is a broken cell, not a measurement), and a
sample rate that some logger could have, so that time stamps read in the wrong unit (seconds taken as ms: a
100 Hz log becomes 100 kHz) are refused at the line the user wrote rather than written and misread later."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rig.errors import SessionFormatError
from rig.io.session_format import COUNT_LIMIT, RAW_LIMITS, TEMP_RANGE_C

# The fastest output data rate of the MEMS inertial sensors we know (32 kHz gyroscopes), with margin: a log
# faster than this is time stamps in a smaller unit than given.
MAX_RATE_HZ = 40_000.0
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}


def check_rate(path: Path, t_s: np.ndarray, column: str, unit: str) -> None:
    """The median step of the time stamps (in seconds) gives a rate a logger can have."""
    if t_s.size < 2:
        return
    step = float(np.median(np.diff(t_s)))
    if step <= 0 or 1.0 / step <= MAX_RATE_HZ:
        return
    given = step / TIME_UNITS[unit]
    rates = {u: 1.0 / (given * f) for u, f in TIME_UNITS.items() if 1.0 / (given * f) <= MAX_RATE_HZ}
    nearest = max(rates, key=rates.get) if rates else None         # the unit one step off, as a slip makes it
    hint = f"; in {nearest} it is {rates[nearest]:g} Hz: give --time-unit {nearest}" if nearest else ""
    raise SessionFormatError(path, f"the time stamps step by {given:g} {unit} (median), a sample rate of "
                             f"{1.0 / step:g} Hz, faster than any inertial sensor logs (at most {MAX_RATE_HZ:g} Hz)"
                             f"{hint}", None, column)


def check_samples(path: Path, cols: dict[str, np.ndarray], sensors: dict[str, list[str]], units: dict[str, str],
                  converted: dict[str, np.ndarray], kept: dict[str, str], first_line: int,
                  temp_column: str | None = None) -> None:
    """Every sample, in the session's unit, within the layout's plausible range; the cell named as written."""
    for sensor, names in sensors.items():
        unit = kept[sensor]
        limit = RAW_LIMITS.get(unit, COUNT_LIMIT)
        values = converted[sensor]
        bad = ~(np.abs(np.nan_to_num(values, nan=0.0)) <= limit)
        if bad.any():
            row, axis = (int(i) for i in np.argwhere(bad)[0])
            written = cols[names[axis]][row]
            raise SessionFormatError(path, f"{written:g} {units.get(sensor, 'counts')} is outside the plausible range "
                                     f"of the {sensor}'s samples (+-{limit:g} {unit})", row + first_line, names[axis])
    if temp_column is not None:
        temp = cols[temp_column]
        lo, hi = TEMP_RANGE_C
        bad = ~((np.nan_to_num(temp, nan=20.0) >= lo) & (np.nan_to_num(temp, nan=20.0) <= hi))
        if bad.any():
            row = int(np.argmax(bad))
            raise SessionFormatError(path, f"{temp[row]:g} degC is outside the plausible range {lo:g} .. {hi:g} degC",
                                     row + first_line, temp_column)
