"""Mounting slots (`[[slots]]` of a rig TOML): several boards on one table, recorded in one session.

Each slot is a unit of its own: its board, serial, buses, place on the table (lever arm from the rotation centre
and mounting rotation, both in the fixture frame of docs/reference/conventions.md) and, where boards share an I2C
address, the channel of a TCA9548A-class switch its I2C parts sit behind. Without `[[slots]]` a configuration
is one unit, as it always was. `slot_config` turns a slot into the single-unit configuration its own session
folder records, so every per-session tool reads a slot unchanged.
"""

from __future__ import annotations

import math
import re
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Mapping

from rig.board import BUS_KEYS, CLOCK_KEYS, placements
from rig.boards import BOARDS

SLOT_KEYS = ("name", "board", "serial", "lever_arm_m", "mount_deg", "i2c_bus", "spi_bus", "mux", "chips")
MUX_KEYS = ("address", "channel")
MUX_ADDRESSES = (0x70, 0x77)        # a TCA9548A's A2..A0 straps
MUX_CHANNELS = 8
LEVER_ARM_LIMIT_M = 1.0             # a board further than this from the rotation centre is not on a turntable
NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")      # a folder name on every file system
DEFAULT_I2C_BUS, DEFAULT_SPI_BUS = 1, 0


@dataclass(frozen=True)
class SlotConfig:
    """One mounting slot: which board sits where on the table and on which buses."""

    name: str                                          # the slot's name, unique; its session folder's name
    board: str                                         # the sensor board in this slot (default: [unit] board)
    serial: str = ""                                   # the unit's serial (simulated and empty: SIM-<seed>-<slot>)
    lever_arm_m: tuple[float, float, float] = (0.0, 0.0, 0.0)   # board origin from the rotation centre, fixture frame, m
    mount_deg: tuple[float, float, float] | None = None         # board frame in the fixture frame: roll, pitch, yaw (Rz Ry Rx)
    i2c_bus: int = DEFAULT_I2C_BUS                     # the slot's I2C bus number (default: [chips] i2c_bus, else 1)
    spi_bus: int = DEFAULT_SPI_BUS                     # the slot's SPI bus number (default: [chips] spi_bus, else 0)
    mux: tuple[int, int] | None = None                 # {address, channel} of the switch its I2C parts sit behind
    chips: Mapping[str, Any] = field(default_factory=dict)     # [slots.chips.<part>] overrides, as [chips.<part>]

    def to_dict(self) -> dict:
        d = asdict(self)
        d["lever_arm_m"] = list(self.lever_arm_m)
        d["mount_deg"] = None if self.mount_deg is None else list(self.mount_deg)
        d["mux"] = None if self.mux is None else {"address": self.mux[0], "channel": self.mux[1]}
        d["chips"] = dict(self.chips)
        return d


def slots_from_dicts(items: list) -> tuple[SlotConfig, ...]:
    """Slots back from their `to_dict` snapshots (a session's metadata); trusted, as written by `to_dict`."""
    out = []
    for d in items or ():
        mux = d.get("mux")
        out.append(SlotConfig(d["name"], d["board"], d.get("serial", ""), tuple(d.get("lever_arm_m", (0, 0, 0))),
                              None if d.get("mount_deg") is None else tuple(d["mount_deg"]),
                              int(d.get("i2c_bus", DEFAULT_I2C_BUS)), int(d.get("spi_bus", DEFAULT_SPI_BUS)),
                              None if mux is None else (int(mux["address"]), int(mux["channel"])),
                              dict(d.get("chips") or {})))
    return tuple(out)


def parse_slots(raw: Any, *, unit_board: str, chips: Mapping, where: str) -> tuple[SlotConfig, ...]:
    """The `[[slots]]` array checked: every key, unique names, no two parts at one bus location.
    A ValueError names the file, the slot and the key."""
    if raw is None:
        return ()
    if not isinstance(raw, list) or not raw or not all(isinstance(s, dict) for s in raw):
        raise ValueError(f"{where}: slots must be an array of tables ([[slots]] sections), at least one")
    slots = []
    for i, table in enumerate(raw):
        slots.append(_slot(table, i, unit_board, chips, where))
    seen: dict[str, int] = {}
    for i, s in enumerate(slots):
        if s.name in seen:
            raise ValueError(f"{where}: [[slots]] #{i + 1} name = {s.name!r}: slot #{seen[s.name] + 1} has that "
                             "name already; each slot's name must be unique (it names the slot's folder)")
        seen[s.name] = i
    _check_collisions(slots, chips, unit_board, where)
    return tuple(slots)


def _slot(table: dict, index: int, unit_board: str, unit_chips: Mapping, where: str) -> SlotConfig:
    name = table.get("name")
    label = f"[[slots]] #{index + 1}"
    if not isinstance(name, str) or not NAME.match(name):
        raise ValueError(f"{where}: {label} name = {name!r} must be a folder-safe name (letters, digits, '_', '-', "
                         "'.'; up to 64; not starting with '.', '_' or '-')")
    label = f"[[slots]] {name}"
    unknown = set(table) - set(SLOT_KEYS)
    if unknown:
        raise ValueError(f"{where}: {label} has unknown keys {sorted(unknown)}; allowed: {list(SLOT_KEYS)}")
    board = table.get("board", unit_board)
    if board not in BOARDS:
        raise ValueError(f"{where}: {label} board = {board!r}; allowed: {list(BOARDS)}")
    serial = table.get("serial", "")
    if not isinstance(serial, str):
        raise ValueError(f"{where}: {label} serial = {serial!r} must be a string")
    lever = _vector(table, "lever_arm_m", (0.0, 0.0, 0.0), LEVER_ARM_LIMIT_M, f"{where}: {label}",
                    "three finite numbers, metres, each within +-1")
    mount = (_vector(table, "mount_deg", None, 360.0, f"{where}: {label}",
                     "three finite numbers (roll, pitch, yaw), degrees, each within +-360")
             if "mount_deg" in table else None)
    buses = {}
    for key, default in (("i2c_bus", DEFAULT_I2C_BUS), ("spi_bus", DEFAULT_SPI_BUS)):
        value = table.get(key, unit_chips.get(key, default))
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ValueError(f"{where}: {label} {key} = {value!r} must be a bus number (0, 1, ...)")
        buses[key] = value
    mux = _mux(table.get("mux"), f"{where}: {label}") if "mux" in table else None
    chips = table.get("chips", {})
    if not isinstance(chips, dict):
        raise ValueError(f"{where}: {label} chips = {chips!r} must be a table ([slots.chips.<part>])")
    bad_bus = set(chips) & set(BUS_KEYS + CLOCK_KEYS)
    if bad_bus:
        raise ValueError(f"{where}: {label} [slots.chips] {sorted(bad_bus)[0]}: a slot's buses are its own keys "
                         f"i2c_bus and spi_bus; a bus's clock is [chips] i2c_clock_hz, for every slot")
    slot = SlotConfig(name, board, serial, lever, mount, buses["i2c_bus"], buses["spi_bus"], mux, dict(chips))
    try:
        placements(board, slot_chips(slot, unit_board, unit_chips))
    except ValueError as e:
        raise ValueError(f"{where}: {label}: {str(e).replace('[chips', '[slots.chips')}") from None
    return slot


def _vector(table: dict, key: str, default, limit: float, where: str, allowed: str):
    value = table.get(key, default)
    if not (isinstance(value, (list, tuple)) and len(value) == 3
            and all(not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) and abs(v) <= limit
                    for v in value)):
        raise ValueError(f"{where} {key} = {value!r} must be {allowed}")
    return tuple(float(v) for v in value)


def _mux(value: Any, where: str) -> tuple[int, int]:
    if not isinstance(value, dict):
        raise ValueError(f"{where} mux = {value!r} must be a table {{address = 0x70, channel = 2}}")
    unknown = set(value) - set(MUX_KEYS)
    if unknown:
        raise ValueError(f"{where} mux has unknown keys {sorted(unknown)}; allowed: {list(MUX_KEYS)}")
    address, channel = value.get("address", MUX_ADDRESSES[0]), value.get("channel")
    lo, hi = MUX_ADDRESSES
    if isinstance(address, bool) or not isinstance(address, int) or not lo <= address <= hi:
        raise ValueError(f"{where} mux address = {address!r} must be a switch address 0x{lo:02x}..0x{hi:02x}")
    if isinstance(channel, bool) or not isinstance(channel, int) or not 0 <= channel < MUX_CHANNELS:
        raise ValueError(f"{where} mux channel = {channel!r} must be a whole number in 0..{MUX_CHANNELS - 1}")
    return address, channel


def slot_chips(slot: SlotConfig, unit_board: str, unit_chips: Mapping) -> dict:
    """The slot's `[chips]` table: its buses, the unit's `[chips.<part>]` where the boards agree, then its own."""
    chips: dict[str, Any] = {"i2c_bus": slot.i2c_bus, "spi_bus": slot.spi_bus,
                             **{k: unit_chips[k] for k in CLOCK_KEYS if k in unit_chips}}
    if slot.board == unit_board:
        chips.update({k: dict(v) for k, v in unit_chips.items() if k not in BUS_KEYS and isinstance(v, Mapping)})
    for part, table in slot.chips.items():
        chips[part] = {**chips.get(part, {}), **table} if isinstance(table, Mapping) else table
    return chips


def _check_collisions(slots: list[SlotConfig], unit_chips: Mapping, unit_board: str, where: str) -> None:
    """Two parts at one bus location would answer together: one I2C address on a bus (a part behind a switch
    channel shows on the bus itself while its channel is selected, so it collides with a part outside the switch,
    and with the switch), one SPI chip select, one GPIO line."""
    taken: dict[tuple, str] = {}        # location -> who holds it
    behind: dict[tuple, str] = {}       # (bus, address) -> a part behind some switch channel there

    def collide(who: str, other: str, what: str) -> ValueError:
        return ValueError(f"{where}: {who} and {other} are both at {what}; give one another address or chip select "
                          "([slots.chips.<part>]), another i2c_bus/spi_bus, or put the slots behind different "
                          "channels of a switch (mux = {address = 0x70, channel = N})")

    def claim(key: tuple, who: str, what: str) -> None:
        if key in taken and taken[key] != who:
            raise collide(who, taken[key], what)
        taken[key] = who

    switches = {(s.i2c_bus, s.mux[0]) for s in slots if s.mux is not None}
    for bus, address in sorted(switches):
        taken["i2c", bus, None, address] = f"the switch at 0x{address:02x}"
    for s in slots:
        for p in placements(s.board, slot_chips(s, unit_board, unit_chips)):
            who = f"[[slots]] {s.name} part {p.name} ({p.chip})"
            if p.bus == "i2c":
                at = f"I2C bus {s.i2c_bus} address 0x{p.address:02x}"
                plain = ("i2c", s.i2c_bus, None, p.address)
                if s.mux is None:
                    if (s.i2c_bus, p.address) in behind:
                        raise collide(who, behind[s.i2c_bus, p.address], at)
                    claim(plain, who, at)
                else:
                    if plain in taken:
                        raise collide(who, taken[plain], at)
                    behind.setdefault((s.i2c_bus, p.address), who)
                    claim(("i2c", s.i2c_bus, s.mux, p.address), who,
                          f"{at} behind switch 0x{s.mux[0]:02x} channel {s.mux[1]}")
            elif p.bus == "spi":
                for cs in (p.cs if isinstance(p.cs, tuple) else (p.cs,)):
                    claim(("spi", s.spi_bus, cs), who, f"SPI bus {s.spi_bus} chip select {cs}")
            if p.gpio is not None:
                claim(("gpio", *p.gpio), who, f"GPIO {p.gpio[0]} line {p.gpio[1]}")


def slot_config(config, slot: SlotConfig):
    """The single-unit configuration of one slot (`rig.config.RigConfig`): what its own session records."""
    return replace(config, board=slot.board, serial=slot.serial or config.serial,
                   chips=slot_chips(slot, config.board, config.chips), slots=())
