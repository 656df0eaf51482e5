"""Write and read the calibration file `rig-calibration/1` (docs/reference/calibration-json.md).

Other programs (firmware generators, notebooks) read this file, so it is strict JSON (no NaN: an
unknown per-sensor number such as a NaN residual is left out, elsewhere it is `null`), written
atomically, and read back with every required field checked
(`u = H (y - B)`, det(H) > 0) so a corrupt or hand-edited file fails loudly, naming the key.
"""

from __future__ import annotations

import json
import math
import os
import re
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

import rig
from rig.calibration.numerics.result import GSensitivity, TriadCalibration
from rig.calibration.thermal.model import TemperatureModelFormatError, ThermalModel
from rig.errors import InputError
from rig.io.atomic import write_text_atomic
from rig.io.text_file import read_utf8
from rig.units import SENSOR_UNITS

SCHEMA = "rig-calibration/1"
TOP_LEVEL_KEYS = ("schema", "created", "software", "unit", "gravity_mps2", "field_uT", "sensors")


class CalibrationFileError(InputError):
    """A calibration file breaks `rig-calibration/1`; names the file and the key."""

    def __init__(self, file: str | os.PathLike, message: str, key: str | None = None) -> None:
        self.file, self.key = str(file), key
        super().__init__(f"{self.file}" + (f", key '{key}'" if key else "") + f": {message}")


def write_calibration(path: str | os.PathLike, sensors: dict[str, TriadCalibration], *, gravity: float,
                      field_uT: float | None, unit_serial: str | None = None, board: str | None = None,
                      extra: dict | None = None, temperature_models: dict[str, ThermalModel] | None = None) -> Path:
    """Write one unit's calibration; `extra` adds top-level keys (it may not replace the schema's own). A file
    without a calibrated sensor is written only where `extra["not_calibrated"]` says why of each: the user reads
    it, and `read_calibration` refuses it for applying, naming those reasons. `temperature_models`: a calibrated
    sensor's B(T), H(T), written as `sensors.<s>.temperature_model`."""
    if not sensors and not (extra or {}).get("not_calibrated"):
        raise ValueError("write_calibration: no sensors to write")
    doc: dict = {
        "schema": SCHEMA,
        "created": datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "software": f"rig {rig.__version__}",
        "unit": {k: v for k, v in (("serial", unit_serial), ("board", board)) if v is not None},
        "gravity_mps2": float(gravity),
    }
    if field_uT is not None:
        doc["field_uT"] = float(field_uT)
    doc["sensors"] = {}
    for name, cal in sensors.items():
        unit = SENSOR_UNITS.get(name)
        if unit is None:
            raise ValueError(f"write_calibration: unknown sensor {name!r}; expected one of {sorted(SENSOR_UNITS)}")
        unit = cal.extra.get("unit", unit)      # a magnetometer in counts calibrated to its own field: counts
        det = float(np.linalg.det(np.asarray(cal.H, dtype=float)))
        if not det > 0:
            raise ValueError(f"write_calibration: sensor {name!r} has det(H) = {det:.3g}; the file requires det(H) > 0")
        entry = _jsonable(cal.to_json_dict(unit))
        doc["sensors"][name] = {k: v for k, v in entry.items() if v is not None}   # unknown: key left out
    for name, model in (temperature_models or {}).items():
        if name not in doc["sensors"]:
            raise ValueError(f"write_calibration: a temperature model for {name!r}, which has no calibration here")
        doc["sensors"][name]["temperature_model"] = model.to_json_dict()
    clash = set(extra or {}) & set(TOP_LEVEL_KEYS)
    if clash:
        raise ValueError(f"write_calibration: extra keys {sorted(clash)} would replace the schema's own")
    doc.update(extra or {})
    text = _compact_vectors(json.dumps(_jsonable(doc), indent=2, allow_nan=False)) + "\n"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_text_atomic(path, text)


# An innermost list of numbers as json.dumps(indent=...) lays it out: it spans raw newlines, which a
# JSON string never contains, so text inside strings is never touched.
_NUMBER_LIST = re.compile(r"\[\n[-+.\deEnul,\s]*\]")


def _compact_vectors(text: str) -> str:
    """Put each innermost list of numbers on one line, so B and the rows of H read as vectors."""
    return _NUMBER_LIST.sub(lambda m: "[" + ", ".join(c.strip() for c in m.group(0)[1:-1].split(",")) + "]", text)


def _jsonable(x):
    """numpy arrays and scalars as lists and numbers; NaN/inf as null (strict JSON)."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        return _jsonable(x.item())
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, Path):
        return str(x)
    return x


def read_calibration(path: str | os.PathLike) -> dict:
    """Parse and validate a calibration file; returns the JSON document as read."""
    path = Path(path)
    text = read_utf8(path, lambda message, line: CalibrationFileError(
        path, message if line is None else f"line {line}: {message}"))
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise CalibrationFileError(path, f"not valid JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None
    if not isinstance(doc, dict):
        raise CalibrationFileError(path, "must hold a JSON object")
    if doc.get("schema") != SCHEMA:
        raise CalibrationFileError(path, f"must be {SCHEMA!r}, got {doc.get('schema')!r}", "schema")
    sensors = doc.get("sensors")
    if isinstance(sensors, dict) and not sensors and isinstance(doc.get("not_calibrated"), dict):
        why = "; ".join(f"{k}: {v}" for k, v in doc["not_calibrated"].items())
        raise CalibrationFileError(path, f"no sensor was calibrated (not_calibrated: {why})", "sensors")
    if not isinstance(sensors, dict) or not sensors:
        raise CalibrationFileError(path, "required: an object with at least one calibrated sensor", "sensors")
    for name, entry in sensors.items():
        _check_sensor(path, f"sensors.{name}", entry)
    for key in ("gravity_mps2", "field_uT"):
        if doc.get(key) is not None and not (_number(doc[key]) and doc[key] > 0):
            raise CalibrationFileError(path, f"must be a positive number, got {doc[key]!r}", key)
    return doc


def _check_sensor(path: Path, key: str, entry) -> None:
    if not isinstance(entry, dict):
        raise CalibrationFileError(path, "must be an object with unit, B and H", key)
    for field in ("unit", "B", "H"):
        if field not in entry:
            raise CalibrationFileError(path, "required field missing", f"{key}.{field}")
    if not isinstance(entry["unit"], str) or not entry["unit"]:
        raise CalibrationFileError(path, f"must be a unit name, got {entry['unit']!r}", f"{key}.unit")
    _array(path, f"{key}.B", entry["B"], (3,))
    H = _array(path, f"{key}.H", entry["H"], (3, 3))
    det = float(np.linalg.det(H))
    if not det > 0:
        raise CalibrationFileError(path, f"det(H) = {det:.6g}; u = H (y - B) requires det(H) > 0 "
                                   "(a right-handed sensor)", f"{key}.H")
    for field, shape in (("B_std", (3,)), ("H_std", (3, 3))):
        if entry.get(field) is not None:
            if (_array(path, f"{key}.{field}", entry[field], shape) < 0).any():
                raise CalibrationFileError(path, "standard deviations cannot be negative", f"{key}.{field}")
    if "temperature_model" in entry:
        _temperature_model(path, key, entry["temperature_model"])
    g = entry.get("g_sensitivity")
    if g is not None:
        if not isinstance(g, dict) or "K" not in g or "f_ref_mps2" not in g:
            raise CalibrationFileError(path, "must be an object with K and f_ref_mps2", f"{key}.g_sensitivity")
        _array(path, f"{key}.g_sensitivity.K", g["K"], (3, 3))
        _array(path, f"{key}.g_sensitivity.f_ref_mps2", g["f_ref_mps2"], (3,))


def _temperature_model(path: Path, key: str, value) -> ThermalModel:
    try:
        return ThermalModel.from_json_dict(key.split(".")[-1], value)
    except TemperatureModelFormatError as e:
        sub = "" if e.key == "temperature_model" else f".{e.key}"
        raise CalibrationFileError(path, e.message, f"{key}.temperature_model{sub}") from None


def temperature_models_from_calibration(doc: dict, path: str | os.PathLike = "calibration.json"
                                        ) -> dict[str, ThermalModel]:
    """The temperature models of a validated calibration document, by sensor (only the sensors that have one)."""
    return {name: _temperature_model(Path(path), f"sensors.{name}", e["temperature_model"])
            for name, e in doc["sensors"].items() if "temperature_model" in e}


def _array(path: Path, key: str, value, shape: tuple[int, ...]) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != shape or _has_non_numbers(value):
        raise CalibrationFileError(path, f"must be {'a 3-vector' if shape == (3,) else 'a 3x3 matrix'} of numbers, "
                                   f"got {json.dumps(value)[:80]}", key)
    if not np.isfinite(arr).all():
        raise CalibrationFileError(path, "holds a non-finite number", key)
    return arr


def _has_non_numbers(value) -> bool:
    if isinstance(value, list):
        return any(_has_non_numbers(v) for v in value)
    return not _number(value)


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def triads_from_calibration(doc: dict) -> dict[str, TriadCalibration]:
    """The sensors of a validated calibration document as `TriadCalibration` objects (to apply them)."""
    out = {}
    for name, e in doc["sensors"].items():
        known = {"unit", "B", "H", "B_std", "H_std", "method", "residual_rms", "iterations", "converged", "warnings",
                 "g_sensitivity"}
        out[name] = TriadCalibration(
            B=np.array(e["B"], dtype=float), H=np.array(e["H"], dtype=float), method=e.get("method", "unknown"),
            residual_rms=float(e["residual_rms"]) if e.get("residual_rms") is not None else float("nan"),
            iterations=int(e.get("iterations", 0)), converged=bool(e.get("converged", True)),
            B_std=np.array(e["B_std"], dtype=float) if e.get("B_std") is not None else None,
            H_std=np.array(e["H_std"], dtype=float) if e.get("H_std") is not None else None,
            warnings=list(e.get("warnings", [])), extra={k: v for k, v in e.items() if k not in known},
            g_sensitivity=_g_sensitivity(e.get("g_sensitivity")))
    return out


def _g_sensitivity(g: dict | None) -> GSensitivity | None:
    if g is None:
        return None
    nan = float("nan")
    return GSensitivity(K=np.array(g["K"], dtype=float), f_ref=np.array(g["f_ref_mps2"], dtype=float),
                        p_value=float(g.get("p_value", nan)), deg_s_per_g=float(g.get("deg_s_per_g", nan)),
                        poses=int(g.get("poses", 0)))
