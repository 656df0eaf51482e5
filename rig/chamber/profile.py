"""Chamber register profiles: a temperature controller's Modbus map as a TOML file.

Controllers (Watlow F4T, others) and the integrators who wire them each have their own map, so the client
never hard-codes an address; `profiles/watlow-f4t.toml` is the default (docs/reference/chamber-map.md).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from rig.chamber.errors import ProfileError

REQUIRED_FLOATS = ("SET_POINT", "PROCESS_VALUE", "RAMP_RATE")
OPTIONAL_FLOATS = ("WORKING_SET_POINT",)
REQUIRED_WORDS = ("RAMP_ACTION", "RAMP_SCALE", "RUN")
OPTIONAL_WORDS = ("DEVICE_STATUS", "DISPLAY_UNITS", "ALARM_STATE")
REQUIRED_VALUES = {"RAMP_ACTION": ("OFF", "SET_POINT"), "RAMP_SCALE": ("PER_MINUTE",), "RUN": ("OFF", "ON"),
                   "DEVICE_STATUS": ("OK",), "DISPLAY_UNITS": ("F", "C"), "ALARM_STATE": ()}
WRITABLE = ("SET_POINT", "RAMP_RATE", "RAMP_ACTION", "RAMP_SCALE", "RUN", "DISPLAY_UNITS")
DEFAULT_PROFILE = "watlow-f4t.toml"


@dataclass(frozen=True)
class ChamberProfile:
    """A chamber controller's register map: where each register is and what its values mean."""

    path: str
    name: str
    device_id: int
    word_order: str
    modbus_units: str                     # "C", "F" or "display" (follow DISPLAY_UNITS)
    ambient_c: float
    min_c: float
    max_c: float
    max_ramp_c_per_min: float
    floats: dict[str, int]
    words: dict[str, int]
    values: dict[str, dict[str, int]]

    def address(self, name: str) -> int:
        return self.floats[name] if name in self.floats else self.words[name]

    def has(self, name: str) -> bool:
        return name in self.floats or name in self.words

    def value_name(self, register: str, value: int) -> str:
        """The profile's name of a word's value, or the number if the profile does not name it."""
        for name, v in self.values.get(register, {}).items():
            if v == value:
                return name
        return str(value)

    def registers(self) -> dict[int, tuple[str, int]]:
        """address -> (name, register count) of every register the profile defines."""
        out = {a: (n, 2) for n, a in self.floats.items()}
        out.update({a: (n, 1) for n, a in self.words.items()})
        return out


def load_profile(path: str | Path | None = None) -> ChamberProfile:
    """Read and check a profile; None loads the packaged Watlow F4T one."""
    if path is None:
        source = resources.files("rig.chamber") / "profiles" / DEFAULT_PROFILE
        label, text = f"<packaged {DEFAULT_PROFILE}>", source.read_text(encoding="utf-8")
    else:
        label = str(path)
        try:
            text = Path(path).read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ProfileError(label, "(file)", "no such file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ProfileError(label, "(file)", f"cannot read: {exc}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(label, "(file)", f"not valid TOML: {exc}") from None
    return _parse(label, data)


def _parse(label: str, data: dict[str, Any]) -> ChamberProfile:
    def need(key: str, kind: type | tuple[type, ...], table: dict[str, Any] = data, prefix: str = "") -> Any:
        if key not in table:
            raise ProfileError(label, prefix + key, "missing")
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, kind):
            raise ProfileError(label, prefix + key, f"must be {_kind(kind)}, got {value!r}")
        return value

    name = need("name", str)
    device_id = need("device_id", int)
    if not 0 <= device_id <= 247:
        raise ProfileError(label, "device_id", f"{device_id} is not a Modbus device id 0..247")
    word_order = need("word_order", str)
    if word_order not in ("big", "little"):
        raise ProfileError(label, "word_order", f"must be 'big' or 'little', got {word_order!r}")
    modbus_units = data.get("modbus_units", "C")
    if modbus_units not in ("C", "F", "display"):
        raise ProfileError(label, "modbus_units", f"must be 'C', 'F' or 'display', got {modbus_units!r}")
    ambient_c = float(need("ambient_c", (int, float)))
    limits = need("limits", dict)
    min_c = float(need("min_c", (int, float), limits, "limits."))
    max_c = float(need("max_c", (int, float), limits, "limits."))
    max_ramp = float(need("max_ramp_c_per_min", (int, float), limits, "limits."))
    if not (math.isfinite(min_c) and math.isfinite(max_c) and min_c < max_c):
        raise ProfileError(label, "limits", f"min_c {min_c} must be below max_c {max_c}")
    if not min_c <= ambient_c <= max_c:
        raise ProfileError(label, "ambient_c", f"{ambient_c} is outside limits {min_c}..{max_c}")
    if not (math.isfinite(max_ramp) and max_ramp > 0):
        raise ProfileError(label, "limits.max_ramp_c_per_min", f"must be positive, got {max_ramp}")
    floats = _addresses(label, "floats", need("floats", dict), REQUIRED_FLOATS, OPTIONAL_FLOATS)
    words = _addresses(label, "words", need("words", dict), REQUIRED_WORDS, OPTIONAL_WORDS)
    if modbus_units == "display" and "DISPLAY_UNITS" not in words:
        raise ProfileError(label, "modbus_units", "'display' needs words.DISPLAY_UNITS")
    taken: dict[int, str] = {}
    for reg, (address, count) in {**{n: (a, 2) for n, a in floats.items()},
                                  **{n: (a, 1) for n, a in words.items()}}.items():
        for k in range(count):
            if address + k in taken:
                raise ProfileError(label, reg, f"register {address + k} overlaps {taken[address + k]}")
            taken[address + k] = reg
    values_table = data.get("values", {})
    if not isinstance(values_table, dict):
        raise ProfileError(label, "values", "must be a table")
    values: dict[str, dict[str, int]] = {}
    for reg, required in REQUIRED_VALUES.items():
        if reg not in words:
            continue
        table = values_table.get(reg, {})
        if not isinstance(table, dict):
            raise ProfileError(label, f"values.{reg}", "must be a table")
        for key in required:
            need(key, int, table, f"values.{reg}.")
        for key, v in table.items():
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 0xFFFF:
                raise ProfileError(label, f"values.{reg}.{key}", f"must be an integer 0..65535, got {v!r}")
        values[reg] = dict(table)
    return ChamberProfile(label, name, device_id, word_order, modbus_units, ambient_c, min_c, max_c, max_ramp,
                          floats, words, values)


def _addresses(label: str, table_name: str, table: dict[str, Any], required: tuple[str, ...],
               optional: tuple[str, ...]) -> dict[str, int]:
    out = {}
    for key, value in table.items():
        if key not in required + optional:
            raise ProfileError(label, f"{table_name}.{key}",
                               f"unknown register; known: {', '.join(required + optional)}")
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFE:
            raise ProfileError(label, f"{table_name}.{key}", f"must be a register address 0..65534, got {value!r}")
        out[key] = value
    for key in required:
        if key not in out:
            raise ProfileError(label, f"{table_name}.{key}", "missing")
    return out


def _kind(kind: type | tuple[type, ...]) -> str:
    names = {int: "an integer", float: "a number", str: "a string", dict: "a table"}
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return " or ".join(names.get(k, k.__name__) for k in kinds)
