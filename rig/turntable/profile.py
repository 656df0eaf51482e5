"""Register-map profiles: the turntable's Modbus map as a TOML file.

Real tables built from servo drives or a PLC each have their own map, so the client never hard-codes
addresses; `profiles/default.toml` encodes the default map `tt-map/1` (turntable-modbus.md).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from rig.turntable.errors import ProfileError

GLOBAL_REGISTERS = ("DEVICE_ID", "MAP_VERSION", "SYS_STATUS", "HEARTBEAT", "WATCHDOG_MS", "SYS_COMMAND")
# name -> (registers, signed); the client knows each register's type, the profile only its place
AXIS_REGISTER_TYPES = {
    "ENABLE": (1, False), "COMMAND": (1, False),
    "TARGET_POS": (2, True), "TARGET_VEL": (2, True), "ACCEL": (2, False), "DECEL": (2, False),
    "SOFT_LIMIT_POS": (2, True), "SOFT_LIMIT_NEG": (2, True),
    "ACTUAL_POS": (2, True), "ACTUAL_VEL": (2, True), "ENCODER_COUNTS": (2, True), "FOLLOWING_ERR": (2, True),
    "STATUS": (1, False), "ALARM_CODE": (1, False), "LAST_ERROR": (1, False), "CMD_SEQ": (1, False),
}
FEEDBACK_REGISTERS = ("ACTUAL_POS", "ACTUAL_VEL", "ENCODER_COUNTS", "FOLLOWING_ERR",
                      "STATUS", "ALARM_CODE", "LAST_ERROR", "CMD_SEQ")
MOTION_REGISTERS = ("TARGET_POS", "TARGET_VEL", "ACCEL", "DECEL")
SYS_STATUS_BITS = ("READY", "ESTOP", "ALARM", "WATCHDOG")
STATUS_BITS = ("ENABLED", "MOVING", "IN_POSITION", "HOMED", "HOMING", "ALARM", "ESTOP", "CMD_REJECTED")
COMMANDS = ("MOVE_ABS", "MOVE_VEL", "STOP", "HOME", "ALARM_RESET")
SYS_COMMANDS = ("ESTOP", "RESET")
MAX_READ = 125  # registers per FC03 (Modbus Application Protocol V1.1b3, 6.3)


@dataclass(frozen=True)
class TableProfile:
    """A turntable register map: where each register is and what its values mean."""

    path: str
    name: str
    device_id: int
    word_order: str
    units_per_degree: float
    expected_device_id: int
    expected_map_version: int
    global_regs: dict[str, int]
    axis_bases: tuple[int, ...]
    axis_names: tuple[str, ...]
    axis_regs: dict[str, int]
    sys_status_bits: dict[str, int]
    status_bits: dict[str, int]
    commands: dict[str, int]
    sys_commands: dict[str, int]
    alarm_codes: dict[int, str]
    last_errors: dict[int, str]

    def addr(self, axis: int, register: str) -> int:
        return self.axis_bases[axis] + self.axis_regs[register]

    def feedback_block(self) -> tuple[int, int]:
        """(offset, count) of the one FC03 per axis that covers every feedback register; found once (every
        status poll asks twice)."""
        block = self.__dict__.get("_feedback_block")
        if block is None:
            lo = min(self.axis_regs[r] for r in FEEDBACK_REGISTERS)
            hi = max(self.axis_regs[r] + AXIS_REGISTER_TYPES[r][0] for r in FEEDBACK_REGISTERS)
            block = self.__dict__["_feedback_block"] = (lo, hi - lo)    # frozen: set past __setattr__
        return block

    def axis_index(self, axis: int | str) -> int:
        if isinstance(axis, str):
            if axis in self.axis_names:
                return self.axis_names.index(axis)
            raise ValueError(f"unknown axis {axis!r}; profile {self.path} names {list(self.axis_names)}")
        if not 0 <= axis < len(self.axis_bases):
            raise ValueError(f"axis {axis} out of range 0..{len(self.axis_bases) - 1}")
        return int(axis)

    def alarm_name(self, code: int) -> str:
        return self.alarm_codes.get(code, f"UNKNOWN_ALARM_{code}")

    def last_error_name(self, code: int) -> str:
        return self.last_errors.get(code, f"UNKNOWN_ERROR_{code}")


def decode_bits(word: int, bits: dict[str, int]) -> frozenset[str]:
    """Names of the set bits; unnamed set bits appear as 'BIT<n>' so nothing is silently dropped."""
    named = {b for b in bits.values()}
    names = {name for name, b in bits.items() if word >> b & 1}
    names |= {f"BIT{b}" for b in range(16) if word >> b & 1 and b not in named}
    return frozenset(names)


def default_profile_path() -> Path:
    return Path(str(resources.files("rig.turntable") / "profiles" / "default.toml"))


def load_profile(path: str | Path | None = None) -> TableProfile:
    """Read and check a profile; `None` gives the packaged default (`tt-map/1`)."""
    path = Path(path) if path is not None else default_profile_path()
    try:
        with open(path, "rb") as f:
            raw = tomllib.load(f)
    except FileNotFoundError:
        raise ProfileError(str(path), "<file>", "no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(str(path), "<file>", f"not valid TOML: {exc}") from None
    return _Reader(str(path), raw).profile()


class _Reader:
    """Pulls typed, range-checked values out of the parsed TOML, naming the key on error."""

    def __init__(self, file: str, raw: dict[str, Any]) -> None:
        self.file, self.raw = file, raw

    def fail(self, key: str, message: str) -> ProfileError:
        return ProfileError(self.file, key, message)

    def get(self, key: str) -> Any:
        node: Any = self.raw
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                raise self.fail(key, "missing")
            node = node[part]
        return node

    def int_in(self, key: str, lo: int, hi: int, value: Any = None) -> int:
        v = self.get(key) if value is None else value
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise self.fail(key, f"must be an integer in {lo}..{hi}, got {v!r}")
        return v

    def table(self, key: str, required: tuple[str, ...], lo: int, hi: int) -> dict[str, int]:
        node = self.get(key)
        if not isinstance(node, dict):
            raise self.fail(key, "must be a table")
        for name in required:
            if name not in node:
                raise self.fail(f"{key}.{name}", "missing")
        return {name: self.int_in(f"{key}.{name}", lo, hi, v) for name, v in node.items()}

    def unique(self, key: str, table: dict[str, int]) -> None:
        seen: dict[int, str] = {}
        for name, v in table.items():
            if v in seen:
                raise self.fail(f"{key}.{name}", f"value {v} already used by '{seen[v]}'")
            seen[v] = name

    def codes(self, key: str) -> dict[int, str]:
        table = self.table(key, ("NONE",), 0, 0xFFFF)
        self.unique(key, table)
        return {v: name for name, v in table.items()}

    def axis_layout(self) -> tuple[tuple[int, ...], tuple[str, ...], dict[str, int]]:
        bases, names = self.get("axes.bases"), self.get("axes.names")
        if not isinstance(bases, list) or len(bases) != 2:
            raise self.fail("axes.bases", f"must list 2 base addresses (outer, inner), got {bases!r}")
        if not isinstance(names, list) or len(names) != 2 or not all(isinstance(n, str) for n in names):
            raise self.fail("axes.names", f"must list 2 names, got {names!r}")
        bases = tuple(self.int_in("axes.bases", 0, 0xFFFF, b) for b in bases)
        regs = self.table("axis_registers", tuple(AXIS_REGISTER_TYPES), 0, 0xFF)
        unknown = set(regs) - set(AXIS_REGISTER_TYPES)
        if unknown:
            raise self.fail(f"axis_registers.{sorted(unknown)[0]}", "unknown register name")
        used: dict[int, str] = {}
        for name, off in regs.items():
            for k in range(AXIS_REGISTER_TYPES[name][0]):
                if off + k in used:
                    raise self.fail(f"axis_registers.{name}", f"overlaps '{used[off + k]}' at offset {off + k:#x}")
                used[off + k] = name
        span = max(regs[r] + AXIS_REGISTER_TYPES[r][0] for r in FEEDBACK_REGISTERS) - min(
            regs[r] for r in FEEDBACK_REGISTERS)
        if span > MAX_READ:
            raise self.fail("axis_registers", f"feedback registers span {span} > {MAX_READ}: not one FC03")
        return bases, tuple(names), regs

    def profile(self) -> TableProfile:
        word_order = self.get("word_order")
        if word_order not in ("big", "little"):
            raise self.fail("word_order", f"must be 'big' or 'little', got {word_order!r}")
        units = self.get("units_per_degree")
        if isinstance(units, bool) or not isinstance(units, (int, float)) or not units > 0:
            raise self.fail("units_per_degree", f"must be a positive number, got {units!r}")
        name = self.get("name")
        if not isinstance(name, str):
            raise self.fail("name", f"must be a string, got {name!r}")
        bases, names, regs = self.axis_layout()
        glob = self.table("global", GLOBAL_REGISTERS, 0, 0xFFFF)
        self.unique("global", glob)
        bits = {k: self.table(k, req, 0, 15) for k, req in
                (("sys_status_bits", SYS_STATUS_BITS), ("status_bits", STATUS_BITS))}
        for k, table in bits.items():
            self.unique(k, table)
        commands = self.table("commands", COMMANDS, 0, 0xFFFF)
        sys_commands = self.table("sys_commands", SYS_COMMANDS, 1, 0xFFFF)
        self.unique("commands", commands)
        self.unique("sys_commands", sys_commands)
        return TableProfile(
            path=self.file, name=name, device_id=self.int_in("device_id", 0, 247),
            word_order=word_order, units_per_degree=float(units),
            expected_device_id=self.int_in("identity.DEVICE_ID", 0, 0xFFFF),
            expected_map_version=self.int_in("identity.MAP_VERSION", 0, 0xFFFF),
            global_regs=glob, axis_bases=bases, axis_names=names, axis_regs=regs,
            sys_status_bits=bits["sys_status_bits"], status_bits=bits["status_bits"],
            commands=commands, sys_commands=sys_commands,
            alarm_codes=self.codes("alarm_codes"), last_errors=self.codes("last_errors"))
