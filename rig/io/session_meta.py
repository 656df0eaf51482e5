"""meta.json of an interchange session folder, parsed and held to the rules session-csv.md gives its keys.

The keys are checked before samples.csv is opened, since they say which columns it must have and how to read
them. `json` keeps no positions, so an error finds the line of the offending key by its quoted name in the
text: the user is sent to the line to fix, not just told the key.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from rig.errors import SessionFormatError
from rig.io.text_file import read_utf8
from rig.io.session_format import FORMAT, REFERENCES, REQUIRED_COLUMNS, SEGMENT_KINDS, SENSOR_AXES, TABLE_COLUMNS, UNITS
from rig.units import SENSOR_UNITS


def read_meta(path: Path) -> dict:
    """Parse and validate meta.json; errors name the line of the offending key."""
    text = read_utf8(path, lambda message, line: SessionFormatError(path, message, line),
                     missing="missing: a session folder holds meta.json and samples.csv")
    try:
        meta = json.loads(text)
    except json.JSONDecodeError as e:
        raise SessionFormatError(path, f"not valid JSON: {e.msg} (character {e.colno})", e.lineno) from None
    if not isinstance(meta, dict):
        raise SessionFormatError(path, "must hold a JSON object", 1)

    def fail(key: str, message: str, where: str | None = None):
        raise SessionFormatError(path, message, _line_of_key(text, where or key.split(".")[-1]), key)

    if meta.get("format") != FORMAT:
        fail("format", f"format must be {FORMAT!r}, got {meta.get('format')!r}")
    if "gravity_mps2" not in meta:
        fail("gravity_mps2", "required key missing (local gravity magnitude, m/s^2)", "format")
    _check_positive(meta["gravity_mps2"], "gravity_mps2", fail)
    sensors = meta.get("sensors")
    if not isinstance(sensors, dict) or not sensors:
        fail("sensors", "required: an object mapping accel/gyro/mag to their three raw columns", "format")
    claimed: set[str] = set()
    for name, names in sensors.items():
        if name not in SENSOR_UNITS:
            fail(f"sensors.{name}", f"unknown sensor {name!r}; expected one of {sorted(SENSOR_UNITS)}")
        if (not isinstance(names, list) or len(names) != 3 or not all(isinstance(c, str) and c for c in names)
                or len(set(names)) != 3):
            fail(f"sensors.{name}", "must list three distinct raw column names in sensor-axis order")
        clash = (claimed | set(REQUIRED_COLUMNS) | set(TABLE_COLUMNS) | {"temp_c", "vsupply_v"}) & set(names)
        if clash:
            fail(f"sensors.{name}", f"column {sorted(clash)[0]!r} is already used by another column or sensor")
        claimed |= set(names)
    if "mag" in sensors and meta.get("field_uT") is None and meta.get("reference", "table") != "none":
        fail("field_uT", "required when a magnetometer is on a table (local field magnitude, uT)", "mag")
    if meta.get("field_uT") is not None:
        _check_positive(meta["field_uT"], "field_uT", fail)
    if meta.get("sample_rate_hz") is not None:
        _check_positive(meta["sample_rate_hz"], "sample_rate_hz", fail)
    if meta.get("initial_rest_s") is not None:
        _check_positive(meta["initial_rest_s"], "initial_rest_s", fail)
    reference = meta.get("reference", "table")
    if reference not in REFERENCES:
        fail("reference", f"must be one of {list(REFERENCES)}, got {reference!r}")
    units = meta.get("units", {})
    if not isinstance(units, dict):
        fail("units", "must be an object: sensor -> unit of its raw columns")
    for name, unit in units.items():
        if name not in UNITS or unit not in UNITS[name]:
            allowed = UNITS.get(name)
            fail(f"units.{name}", f"unit {unit!r} for {name!r}; allowed: "
                 + (", ".join(allowed) if allowed else f"a sensor among {sorted(UNITS)}"))
    segments = meta.get("segments")
    if segments is not None:
        _check_segments(segments, fail)
    table = meta.get("table")
    if table is not None:
        if not isinstance(table, dict):
            fail("table", "must be an object with outer_axis_world and inner_axis_fixture")
        for key in ("outer_axis_world", "inner_axis_fixture"):
            v = table.get(key)
            if v is not None and not (isinstance(v, list) and len(v) == 3 and all(_is_number(x) for x in v)
                                      and any(x != 0 for x in v)):
                fail(f"table.{key}", "must be a non-zero 3-vector")
    return meta


def _check_segments(segments, fail) -> None:
    """The known facts of a recording without a turntable (session-csv.md): named intervals of t, in time order."""
    if not isinstance(segments, list):
        fail("segments", "must be a list of {name, t0, t1, kind, ...} objects")
    last_t0 = -math.inf
    for k, seg in enumerate(segments):
        where = f"segments[{k}]"
        if not isinstance(seg, dict):
            fail(where, "must be an object", "segments")
        name = seg.get("name", k)
        label = f"{where} ({name})"
        for key in ("t0", "t1"):
            if not (_is_number(seg.get(key)) and math.isfinite(seg[key])):
                fail(f"{label}.{key}", f"must be a finite number of seconds, got {seg.get(key)!r}", "segments")
        if not seg["t0"] < seg["t1"]:
            fail(f"{label}.t1", f"t1 = {seg['t1']!r} must be after t0 = {seg['t0']!r}", "segments")
        if seg["t0"] < last_t0:
            fail(f"{label}.t0", "segments must be listed in time order", "segments")
        last_t0 = seg["t0"]
        kind = seg.get("kind")
        if kind not in SEGMENT_KINDS:
            fail(f"{label}.kind", f"must be one of {list(SEGMENT_KINDS)}, got {kind!r}", "segments")
        axis_key = "up" if kind == "static" else "axis"
        if (kind == "rotation" or seg.get("up") is not None) and seg.get(axis_key) not in SENSOR_AXES:
            fail(f"{label}.{axis_key}", f"must be one of {list(SENSOR_AXES)}, got {seg.get(axis_key)!r}", "segments")
        if kind == "rotation" and not (_is_number(seg.get("angle_deg")) and math.isfinite(seg["angle_deg"])
                                       and seg["angle_deg"] != 0):
            fail(f"{label}.angle_deg", f"must be a non-zero number (signed, right-hand rule), got "
                 f"{seg.get('angle_deg')!r}", "segments")
        for key in ("tilt_deg_sd", "angle_deg_sd"):
            if key in seg and not (_is_number(seg[key]) and math.isfinite(seg[key]) and seg[key] > 0):
                fail(f"{label}.{key}", f"must be a positive number of degrees, got {seg[key]!r}", "segments")


def _check_positive(value, key: str, fail) -> None:
    if not (_is_number(value) and math.isfinite(value) and value > 0):
        fail(key, f"must be a positive number, got {value!r}")


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _line_of_key(text: str, key: str) -> int | None:
    needle = f'"{key}"'
    for i, line in enumerate(text.splitlines(), 1):
        if needle in line:
            return i
    return None
