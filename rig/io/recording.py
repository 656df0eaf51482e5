"""A recording without a turntable as an ordinary session (session-csv.md, "Recordings without a turntable").

Every importer (imu_tk ASCII, imucal's Ferraris layouts, a generic CSV) ends here: the samples, the units
they are in, and what is known of their intervals (`segments`). The rows of a static segment become a hold
of the session (one step per static segment, in time order) and every other row a move, so commands that
look at holds see the faces; a recording with no static segment has no phases at all.
"""

from __future__ import annotations

import numpy as np

from rig.errors import InputError
from rig.session_data import SessionData, no_reference
from rig.units import STANDARD_GRAVITY

DEFAULT_COLUMNS = {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]}
# Units a user may name on import -> (unit the session keeps, factor): what the layout allows is kept as it is.
IMPORT_UNITS = {
    "accel": {"counts": ("counts", 1.0), "m/s^2": ("m/s^2", 1.0), "g": ("m/s^2", STANDARD_GRAVITY)},
    "gyro": {"counts": ("counts", 1.0), "deg/s": ("deg/s", 1.0), "rad/s": ("rad/s", 1.0)},
    "mag": {"counts": ("counts", 1.0), "uT": ("uT", 1.0), "gauss": ("uT", 100.0), "mG": ("uT", 0.1)},
}


def recording_session(t: np.ndarray, raw: dict[str, np.ndarray], *, units: dict[str, str], source: str,
                      gravity: float = STANDARD_GRAVITY, field_uT: float | None = None,
                      segments: list[dict] | None = None, temp_c: np.ndarray | None = None,
                      sample_rate_hz: float | None = None, imported: dict | None = None,
                      initial_rest_s: float | None = None) -> SessionData:
    """The session of one recording; `imported` (what was read, how) is kept in its metadata, and so is
    `initial_rest_s`, the rest the user says the recording starts with (imu_tk's initial static interval, which
    sets its static threshold and the gyro's bias; 50 s when not said)."""
    t = np.asarray(t, dtype=float)
    n = len(t)
    segments = sorted(segments or [], key=lambda s: s["t0"])
    step = np.full(n, -1, dtype=np.int64)
    is_move = np.ones(n, dtype=bool)
    statics = [s for s in segments if s["kind"] == "static"]
    for k, seg in enumerate(statics):
        rows = (t >= seg["t0"]) & (t <= seg["t1"])
        step[rows], is_move[rows] = k, False
    if statics:
        holds = np.where(~is_move, step, -1)
        left = np.maximum.accumulate(holds)            # the hold a move row leaves (0 before the first)
        step = np.where(is_move, np.maximum(left, 0), step)
    meta = {"reference": "none", "units": {s: units.get(s, "counts") for s in raw}, "segments": segments,
            "imported": imported or {}, **({"initial_rest_s": float(initial_rest_s)} if initial_rest_s else {})}
    return SessionData(t=t, is_move=is_move, step=step, q_ref=no_reference(n),
                       raw={s: np.asarray(y, dtype=float) for s, y in raw.items()},
                       columns={s: list(DEFAULT_COLUMNS[s]) for s in raw}, gravity=float(gravity),
                       field_uT=None if field_uT is None else float(field_uT), sample_rate_hz=sample_rate_hz,
                       temp_c=temp_c, meta=meta, source=source)


def parse_units(text: str | None, sensors: list[str]) -> dict[str, str]:
    """`accel=m/s^2,gyro=deg/s` -> {sensor: unit}; unnamed sensors are counts. InputError names the bad part."""
    units = {s: "counts" for s in sensors}
    for part in (text or "").split(","):
        if not part.strip():
            continue
        sensor, _, unit = part.partition("=")
        sensor, unit = sensor.strip(), unit.strip()
        if sensor not in IMPORT_UNITS:
            raise InputError(f"--units {part!r}: unknown sensor {sensor!r}; one of {', '.join(IMPORT_UNITS)}")
        if unit not in IMPORT_UNITS[sensor]:
            raise InputError(f"--units {part!r}: {sensor} may be in {', '.join(IMPORT_UNITS[sensor])}")
        units[sensor] = unit
    return units


def to_session_units(raw: dict[str, np.ndarray], units: dict[str, str]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Values in a unit the layout does not carry (g, gauss) converted to one it does (m/s^2, uT)."""
    out, kept = {}, {}
    for sensor, y in raw.items():
        unit, factor = IMPORT_UNITS[sensor][units.get(sensor, "counts")]
        out[sensor], kept[sensor] = np.asarray(y, dtype=float) * factor, unit
    return out, kept


def check_counts(raw: dict[str, np.ndarray], units: dict[str, str],
                 where: dict[str, tuple[str, list[str], np.ndarray]]) -> None:
    """Counts must be whole numbers: a fractional value means the column is already scaled, and reading it as
    counts would calibrate nonsense. InputError names the file, line and column and says how to state units.
    `where[sensor]` = (file, its three column names, the file line of each row)."""
    for sensor, y in raw.items():
        if units.get(sensor, "counts") != "counts":
            continue
        frac = ~np.isnan(y) & (y != np.round(y))
        if frac.any():
            row, axis = np.argwhere(frac)[0]
            path, columns, lines = where[sensor]
            raise InputError(f"{path}, line {int(lines[row])}, column '{columns[axis]}': {y[row, axis]:g} is not a whole "
                             f"count; if the {sensor} is already in physical units, say so with --units "
                             f"{sensor}={'m/s^2' if sensor == 'accel' else 'deg/s' if sensor == 'gyro' else 'uT'}")
