"""A sensor board built from its declaration (`rig.boards`): each part attached to open buses, composed into
the triads a procedure reads. The buses are given already open, real or fake: this module never knows which.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping

from drivers.contract import Part, Placement, Sensor, SupplyMonitor, Thermometer, Wiring
from drivers.registry import chip_class
from rig.boards import BOARDS, BoardSpec

BUS_KEYS = ("i2c_bus", "spi_bus")
I2C_CLOCKS_HZ = (100_000, 400_000)      # standard and fast mode, which every I2C chip of the boards supports
CLOCK_KEYS = ("i2c_clock_hz",)
LOCATION_KEYS = ("bus", "address", "cs", "channels", "gpio_chip", "gpio_line")


@dataclass
class SensorBoard:
    kind: str
    triads: dict[str, Sensor]
    parts: list[Part]
    temperature: Callable[[], float] | None = None
    supply: Callable[[], float] | None = None
    placement: dict = field(default_factory=dict)

    def start(self) -> None:
        for part in self.parts:
            part.start()

    def read_temperature(self) -> float | None:
        return None if self.temperature is None else self.temperature()

    def read_supply(self) -> float | None:
        return None if self.supply is None else self.supply()

    def settings(self) -> dict:
        out: dict[str, Any] = {"board": self.kind, "placement": self.placement}
        for name, triad in self.triads.items():
            out[name] = triad.settings()
        return out


def board_spec(kind: str) -> BoardSpec:
    if kind not in BOARDS:
        raise ValueError(f"unknown board {kind!r}; allowed: {sorted(BOARDS)}")
    return BOARDS[kind]


def placements(kind: str, chips: Mapping | None = None) -> tuple[Placement, ...]:
    """The board's placements with `[chips.<part>]` overrides applied; any unknown key is a ValueError."""
    spec = board_spec(kind)
    chips = dict(chips or {})
    unknown = set(chips) - set(BUS_KEYS) - set(CLOCK_KEYS) - set(spec.names)
    if unknown:
        raise ValueError(f"[chips] has unknown keys {sorted(unknown)}; allowed: {list(BUS_KEYS + CLOCK_KEYS)} and one "
                         f"table "
                         f"per part of the {kind} board: {list(spec.names)}")
    for key in BUS_KEYS:
        if key in chips and (isinstance(chips[key], bool) or not isinstance(chips[key], int) or chips[key] < 0):
            raise ValueError(f"[chips] {key} = {chips[key]!r} must be a bus number (0, 1, ...)")
    i2c_clock_hz(chips)
    return tuple(_override(p, chips.get(p.name)) for p in spec.parts)


def i2c_clock_hz(chips: Mapping | None) -> int:
    """[chips] i2c_clock_hz: the I2C bus's SCL frequency (the bus budget times transfers at it), 100 kHz unless
    set; only the standard and fast-mode clocks are allowed."""
    value = (chips or {}).get("i2c_clock_hz", I2C_CLOCKS_HZ[0])
    if isinstance(value, bool) or value not in I2C_CLOCKS_HZ:
        raise ValueError(f"[chips] i2c_clock_hz = {value!r}; allowed: {', '.join(map(str, I2C_CLOCKS_HZ))} (Hz)")
    return int(value)


def _override(p: Placement, table: Any) -> Placement:
    if table is None:
        return p
    where = f"[chips.{p.name}]"
    if not isinstance(table, Mapping):
        raise ValueError(f"{where} must be a table of settings, got {table!r}")
    cls = chip_class(p.chip)
    allowed = LOCATION_KEYS + cls.OPTIONS
    unknown = set(table) - set(allowed)
    if unknown:
        raise ValueError(f"{where} has unknown keys {sorted(unknown)}; allowed for {p.chip}: {list(allowed)}")
    changes: dict[str, Any] = {}
    if "bus" in table:
        if table["bus"] not in cls.BUSES:
            raise ValueError(f"{where} bus = {table['bus']!r}; {p.chip} sits on {list(cls.BUSES)}")
        changes["bus"] = table["bus"]
    if "address" in table:
        changes["address"] = _int(table["address"], where, "address", 0x03, 0x77)
    if "cs" in table:
        cs = table["cs"]
        changes["cs"] = (tuple(_int(c, where, "cs", 0, 255) for c in cs) if isinstance(cs, list)
                         else _int(cs, where, "cs", 0, 255))
    if "channels" in table:
        if not isinstance(table["channels"], list):
            raise ValueError(f"{where} channels = {table['channels']!r} must be a list of ADC channels")
        changes["channels"] = tuple(_int(c, where, "channels", 0, 7) for c in table["channels"])
    if "gpio_chip" in table or "gpio_line" in table:
        chip, line = p.gpio or ("/dev/gpiochip0", None)
        chip = table.get("gpio_chip", chip)
        if not isinstance(chip, str):
            raise ValueError(f"{where} gpio_chip = {chip!r} must be a path such as /dev/gpiochip0")
        line = _int(table["gpio_line"], where, "gpio_line", 0, 1023) if "gpio_line" in table else line
        if line is None:
            raise ValueError(f"{where} gpio_chip needs gpio_line (the line offset on that chip)")
        changes["gpio"] = (chip, line)
    options = {k: v for k, v in table.items() if k in cls.OPTIONS}
    if options:
        changes["options"] = {**p.options, **options}
    return replace(p, **changes)


def _int(value: Any, where: str, key: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ValueError(f"{where} {key} = {value!r} must be a whole number in {lo}..{hi}")
    return value


def build_board(kind: str, wiring: Wiring | Mapping[str, Wiring], *, chips: Mapping | None = None) -> SensorBoard:
    """The board `kind` with every part attached to `wiring` (or to `wiring[part name]`, real or fake per part)."""
    spec = board_spec(kind)
    built: dict[str, Part] = {}
    home: dict[str, Wiring] = {}
    for p in placements(kind, chips):
        w = wiring[p.name] if isinstance(wiring, Mapping) else wiring
        if p.adc is not None and p.adc in home and home[p.adc] is not w:
            raise ValueError(f"{p.name} ({p.chip}) is read through {p.adc}: both must be real or both fake")
        w.parts.update(built)
        try:
            built[p.name] = chip_class(p.chip).attach(p, w)
        except (ValueError, TypeError) as e:     # a chip setting the driver refuses (rate_hz = -50 or "fast")
            raise ValueError(f"[chips.{p.name}] ({p.chip}): {e}") from None
        home[p.name] = w
    triads = {t: built[name].sensor(t) for t, name in spec.triads.items()}
    temperature = supply = None
    if spec.temperature is not None:
        part = built[spec.temperature]
        if not isinstance(part, Thermometer):
            raise ValueError(f"board {kind}: {spec.temperature} ({part.chip}) has no temperature sensor")
        temperature = part.read_temperature
    if spec.supply is not None:
        part = built[spec.supply]
        if not isinstance(part, SupplyMonitor):
            raise ValueError(f"board {kind}: {spec.supply} ({part.chip}) does not monitor the supply")
        supply = part.read_supply_v
    return SensorBoard(kind, triads, list(built.values()), temperature, supply, _describe(placements(kind, chips)))


def _describe(parts: tuple[Placement, ...]) -> dict:
    out = {}
    for p in parts:
        d = {"chip": p.chip, "bus": p.bus}
        for key in ("address", "cs", "adc", "channels", "gpio"):
            value = getattr(p, key)
            if value is not None:
                d[key] = list(value) if isinstance(value, tuple) else value
        out[p.name] = {**d, **dict(p.options)}
    return out
