"""MkDocs hook: the configuration keys' reference, generated from their declarations at build time.

The page `reference/configuration.md` holds the marker `<!-- generated: configuration-keys -->`; this hook
replaces it with one table per section of a rig TOML. Names, defaults, ranges and allowed values come from the
code that reads the file (`rig.config`: SECTIONS, the section dataclasses, RANGES; `rig.board` and
`rig.boards` for [chips]; `rig.report.metrics` for [limits]; `rig.sim_faults` for [sim.faults]; the drivers'
OPTIONS and their constructors' defaults). A key's meaning is its declaration's own comment where it has one,
else an entry of MEANINGS below. The build fails (strict) when a key the code reads has no meaning, when
MEANINGS names a key the code no longer reads, or when a section has no table here: the page cannot fall behind.
"""

from __future__ import annotations

import dataclasses
import inspect
import io
import tokenize

from drivers.registry import chip_class
from rig import config as cfg
from rig.board import BUS_KEYS, CLOCK_KEYS, I2C_CLOCKS_HZ, LOCATION_KEYS
from rig.boards import BOARDS
from rig.report.metrics import METRICS
from rig.rotations import TableGeometry
from rig.sim_faults import _FAULT_RANGES, MODBUS_EXCEPTION_CODES, SimFaults
from rig.slot_config import LEVER_ARM_LIMIT_M, MUX_ADDRESSES, MUX_CHANNELS, SLOT_KEYS, SlotConfig

MARKER = "<!-- generated: configuration-keys -->"

# Meanings of keys whose declaration carries no comment: (section, key) -> text.
MEANINGS = {
    ("unit", "serial"): "the unit's serial number, kept in every session's metadata and in the lab's store",
    ("unit", "board"): "the sensor board: which chips sit where (`rig/boards.py`)",
    ("unit", "operator"): "who runs the session, kept in the metadata",
    ("turntable", "url"): "the table's line: `tcp://HOST:PORT` (Modbus TCP), `rtu+socket://HOST:PORT` (RTU through "
                          "a serial-to-Ethernet gateway) or `rtu:///dev/ttyUSB0?baud=115200&parity=N` (RTU on a "
                          "serial line)",
    ("turntable", "profile"): "the table's register map, a TOML file (a path relative to this configuration); "
                              "default: the packaged `tt-map/1`",
    ("turntable", "speed_dps"): "the speed of every move, deg/s",
    ("chamber", "url"): "the chamber controller's line, in the form of the table's `url`",
    ("thermal", "steps_c"): "the set points, C (in any order; each visited once per sweep); empty: `steps` from "
                            "`low_c` to `high_c`",
    ("thermal", "low_c"): "the coldest set point when `steps_c` is empty, C",
    ("thermal", "high_c"): "the hottest set point when `steps_c` is empty, C",
    ("thermal", "steps"): "how many set points from `low_c` to `high_c`, evenly",
    ("thermal", "direction"): "`\"up\"` (coldest first), `\"down\"`, or `\"up-down\"` (up, then down through the "
                              "same points, the hottest once)",
    ("turntable", "accel_dps2"): "the acceleration and deceleration of every move, deg/s^2",
    ("turntable", "tolerance_deg"): "the in-position window: how close to its target an axis must be, deg",
    ("turntable", "settle_s"): "time in position before a hold starts, s (with emulated chips following a real "
                               "table it must exceed two poll intervals)",
    ("table", "outer_axis_world"): "the outer axis in the world frame (a direction; the tumble configuration by "
                                   "default)",
    ("table", "inner_axis_fixture"): "the inner axis in the fixture frame",
    ("table", "outer_zero_deg"): "the outer encoder's zero offset",
    ("table", "inner_zero_deg"): "the inner encoder's zero offset",
    ("schedule", "orientations"): "how many orientations a session visits (10 to 20 is usual; the ellipsoid "
                                  "needs 9)",
    ("schedule", "hold_s"): "how long each orientation is held, s (1.5 or more lets bump detection judge three "
                            "0.5 s windows)",
    ("schedule", "rate_hz"): "the sample grid every sensor is read on, Hz",
    ("schedule", "mag_every"): "the magnetometer is read every N-th tick of the grid",
    ("schedule", "max_hold_attempts"): "how often a hold that shows motion (a bump) is tried",
    ("environment", "gravity_mps2"): "the local gravity G the accelerometer is calibrated to",
    ("environment", "field_uT"): "the local magnetic field magnitude M the magnetometer is calibrated to",
    ("sim", "chips"): "which parts are emulated: `\"fake\"`, `\"real\"`, or a table part -> `\"fake\"`/`\"real\"`; "
                      "default: all fake under `--sim`, all real with `--config` alone",
    ("sim", "turntable"): "the table emulated (`\"fake\"`, served in this process) or `\"real\"` (the `url`)",
    ("sim", "table_link"): "the line to the fake table: Modbus TCP, RTU through a gateway, RTU on a pty",
    ("sim", "faults"): "faults of the simulated hardware, a table (below)",
    ("sim.faults", "i2c_nack_at_s"): "instants at which the NACK bursts start",
    ("sim.faults", "i2c_nack_s"): "the length of each NACK burst",
    ("sim.faults", "adxrs453_parity_s"): "the length of each run of parity errors",
    ("sim.faults", "adxrs453_fault_s"): "the length of each run of FAULT bits",
    ("sim.faults", "chip_reset_at_s"): "instants at which that part resets",
    ("sim.faults", "bump_amplitude_deg"): "the size of each knock, deg",
    ("sim.faults", "modbus_exception_code"): "the Modbus exception code those requests are answered with",
    ("sim.faults", "adxrs453_fault_bits"): "the FAULT bits asserted",
    ("store", "url"): "the lab's store a session is mirrored into as it runs: a `postgresql://` URL or a folder",
    ("store", "rig"): "this rig's name in the store (default: the host name)",
    ("chips", "i2c_bus"): "the I2C bus number (`/dev/i2c-N`)",
    ("chips", "spi_bus"): "the SPI bus number (`/dev/spidevB.C`)",
    ("chips", "i2c_clock_hz"): "the I2C bus's SCL clock, Hz: what `rig plan`'s bus budget times the transfers at "
                               "(set the bus itself to it in the rig computer's device tree)",
}

# Allowed values checked in code rather than declared in rig.config.RANGES (tests/docs checks each claim).
CHECKED_RANGES = {("schedule", "orientations"): (9, 64)}

# Defaults that live where the value is used rather than in a declaration: (section, key) -> (default, where).
USED_DEFAULTS = {
    ("chips", "i2c_bus"): (1, "rig.assembly"),
    ("chips", "spi_bus"): (0, "rig.assembly"),
}

LOCATION_MEANINGS = {
    "bus": "the bus the part sits on (one its driver supports)",
    "address": "I2C 7-bit address (0x03-0x77)",
    "cs": "SPI chip select, or a list of them (a triad of single-axis gyros)",
    "channels": "ADC channels of an analog sensor (0-7)",
    "gpio_chip": "the GPIO chip of a control line (e.g. `/dev/gpiochip0`)",
    "gpio_line": "the line offset on that chip",
}


def field_comments(cls) -> dict[str, str]:
    """Each dataclass field's trailing comment on its own line of `cls`'s source ('' where it has none)."""
    names = {f.name for f in dataclasses.fields(cls)}
    out: dict[str, str] = {}
    tokens = tokenize.generate_tokens(io.StringIO(inspect.getsource(cls)).readline)
    line_start, current = True, None
    for tok in tokens:
        if tok.type in (tokenize.NEWLINE, tokenize.NL):
            line_start, current = True, None
            continue
        if tok.type in (tokenize.INDENT, tokenize.DEDENT):
            continue
        if line_start and tok.type == tokenize.NAME and tok.string in names:
            current = tok.string
            out.setdefault(current, "")
        elif tok.type == tokenize.COMMENT and current is not None:
            out[current] = tok.string.lstrip("#").strip()
        line_start = False
    return out


def toml_value(value) -> str:
    """A Python default as it would be written in TOML."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    return "(none)" if value is None else str(value)


def number(value) -> str:
    """A bound as a reader writes it: 2^63 rather than 9.22337e+18, 1000000 rather than 1e+06."""
    if isinstance(value, int) and value > 2 ** 20 and value & (value - 1) == 0:
        return f"2^{value.bit_length() - 1}"
    if float(value).is_integer() and abs(value) < 1e9:
        return str(int(value))
    return f"{value:g}"


def cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


class Missing(Exception):
    """A key the code reads that the page cannot explain, or an explanation of a key the code does not read."""


def _meaning(section: str, key: str, comment: str = "", used: set | None = None) -> str:
    if used is not None:
        used.add((section, key))
    if (section, key) in MEANINGS:
        return MEANINGS[section, key] + (f" ({comment})" if comment else "")
    if (section, key) in cfg.RANGES and not comment:
        comment = cfg.RANGES[section, key][2]
    if comment:
        return comment
    raise Missing(f"[{section}] {key}: the code reads it but neither its declaration's comment nor MEANINGS in "
                  f"{__file__} says what it is")


def _table(rows: list[tuple]) -> list[str]:
    out = ["| key | default | allowed | meaning |", "| --- | --- | --- | --- |"]
    out += [f"| `{key}` | `{cell(default)}` | {cell(allowed)} | {cell(meaning)} |" for key, default, allowed, meaning
            in rows]
    return out


def generate() -> str:
    """The generated Markdown: one section per section of a rig TOML."""
    used: set = set()
    rendered: set = set()
    parts: list[str] = []
    rig_defaults = cfg.RigConfig()

    def ranged(section: str, key: str) -> str:
        if (section, key) in cfg.RANGES:
            lo, hi, _ = cfg.RANGES[section, key]
            return f"{number(lo)} to {number(hi)}"
        return ""

    def dataclass_rows(section: str, cls) -> list[tuple]:
        comments = field_comments(cls)
        defaults = cls()
        rows = []
        for f in dataclasses.fields(cls):
            value = getattr(defaults, f.name)
            allowed = ranged(section, f.name)
            if not allowed and isinstance(value, bool):
                allowed = "true, false"
            elif not allowed and (isinstance(value, str) or value is None):
                allowed = "a string"
            if (section, f.name) in CHECKED_RANGES:
                allowed = "{} to {}".format(*CHECKED_RANGES[section, f.name])
            rows.append((f.name, toml_value(value), allowed, _meaning(section, f.name, comments.get(f.name, ""),
                                                                      used)))
        return rows

    # [unit]
    rendered.add("unit")
    unit_allowed = {"board": ", ".join(f"`{name}`" for name in BOARDS)}
    parts += ["## `[unit]`", ""] + _table(
        [(key, toml_value(getattr(rig_defaults, key)), unit_allowed.get(key, "a string"), _meaning("unit", key,
                                                                                                   used=used))
         for key in cfg.SECTIONS["unit"]]) + [""]

    # [turntable]
    rendered.add("turntable")
    parts += ["## `[turntable]`", "", "The table and its moves (`rig.config.TurntableConfig`).", ""]
    parts += _table(dataclass_rows("turntable", cfg.TurntableConfig)) + [""]

    # [chamber]
    rendered.add("chamber")
    parts += ["## `[chamber]`", "", "The thermal chamber's controller (`rig.config.ChamberConfig`); without the "
              "section the rig has no chamber. Its profile is a chamber register profile "
              "([chamber map](chamber-map.md), [guide](../guides/chamber.md)).", ""]
    parts += _table(dataclass_rows("chamber", cfg.ChamberConfig)) + [""]

    # [thermal]
    rendered.add("thermal")
    parts += ["## `[thermal]`", "", "A thermal session's temperature steps, soaks and each step's schedule "
              "(`rig.config.ThermalConfig`); with the section `rig calibrate` runs a thermal session "
              "([guide](../guides/thermal-session.md)). It needs a `[chamber]`.", ""]
    parts += _table(dataclass_rows("thermal", cfg.ThermalConfig)) + [""]

    # [table]
    rendered.add("table")
    geometry = TableGeometry()
    rows = []
    for key in cfg.SECTIONS["table"]:
        value = getattr(geometry, key)
        allowed = "three finite numbers, not all zero" if isinstance(value, tuple) else "a finite number (deg)"
        rows.append((key, toml_value(value), allowed, _meaning("table", key, used=used)))
    parts += ["## `[table]`", "", "The table's geometry ([frames](conventions.md)); the tumble configuration by "
              "default (`rig.rotations.TableGeometry`).", ""] + _table(rows) + [""]

    # [schedule]
    rendered.add("schedule")
    parts += ["## `[schedule]`", "", "What a session visits and how it samples (`rig.config.ScheduleConfig`).", ""]
    parts += _table(dataclass_rows("schedule", cfg.ScheduleConfig)) + [""]

    # [environment]
    rendered.add("environment")
    parts += ["## `[environment]`", ""] + _table(
        [(key, toml_value(getattr(rig_defaults, key)), "a positive finite number", _meaning("environment", key,
                                                                                            used=used))
         for key in cfg.SECTIONS["environment"]]) + [""]

    # [limits.<sensor>]
    rendered.add("limits")
    parts += ["## `[limits.<sensor>]`", "",
              "Acceptance limits, one table per sensor the board has (`accel`, `gyro`, `mag`): each key bounds one "
              "metric from above, and the session's verdict is PASS only if every limit holds "
              "(`rig.report.limits`, `rig.report.metrics`). A limit whose metric cannot be computed does not pass. "
              "No limits: the verdict is NOT CHECKED.", "",
              "| key | meaning | unit |", "| --- | --- | --- |"]
    calibrated = "the sensor's calibrated unit"
    parts += [f"| `{metric}_max` | {cell(meaning)} | {cell(unit.replace('{unit}', calibrated))} |"
              for metric, (meaning, unit) in METRICS.items()] + [""]

    # [chips]
    rendered.add("chips")
    parts += ["## `[chips]`", "",
              "The buses, and one table `[chips.<part>]` per part to move or re-set a part of the board (on the real "
              "and the simulated rig alike).", ""]
    rows = []
    for key in BUS_KEYS:
        default, where = USED_DEFAULTS["chips", key]
        rows.append((key, toml_value(default), "a bus number (0, 1, ...)", _meaning("chips", key, used=used)))
    for key in CLOCK_KEYS:
        rows.append((key, toml_value(I2C_CLOCKS_HZ[0]), " or ".join(map(str, I2C_CLOCKS_HZ)),
                     _meaning("chips", key, used=used)))
    parts += _table(rows) + [""]
    parts += ["Keys of `[chips.<part>]`: where the part sits, and the chip's own settings.", "",
              "| key | meaning |", "| --- | --- |"]
    parts += [f"| `{key}` | {cell(LOCATION_MEANINGS[key])} |" for key in LOCATION_KEYS] + [""]
    missing = set(LOCATION_KEYS) - set(LOCATION_MEANINGS)
    if missing:
        raise Missing(f"[chips.<part>] keys {sorted(missing)} have no meaning in LOCATION_MEANINGS ({__file__})")
    for board in BOARDS.values():
        parts += [f"### Board `{board.name}`", "", board.description + ".", "",
                  "| part | chip | bus | where | settings (`[chips.<part>]` keys, board's values or the driver's "
                  "defaults) |", "| --- | --- | --- | --- | --- |"]
        for p in board.parts:
            cls = chip_class(p.chip)
            where = []
            if p.address is not None:
                where.append(f"address `0x{p.address:02X}`")
            if p.cs is not None:
                where.append(f"cs `{toml_value(p.cs) if isinstance(p.cs, tuple) else p.cs}`")
            if p.adc is not None:
                where.append(f"through `{p.adc}`, channels `{toml_value(p.channels)}`")
            if p.gpio is not None:
                where.append(f"GPIO `{p.gpio[0]}` line `{p.gpio[1]}`")
            settings = []
            try:
                signature = inspect.signature(cls.__init__).parameters
            except (TypeError, ValueError):
                signature = {}
            for option in cls.OPTIONS:
                if option in p.options:
                    value = p.options[option]
                elif option in signature and signature[option].default is not inspect.Parameter.empty:
                    value = signature[option].default
                else:
                    value = None
                settings.append(f"`{option}` = `{toml_value(value)}`" if value is not None else f"`{option}`")
            parts.append(f"| `{p.name}` | {cell(p.chip)} | {p.bus} | {cell(', '.join(where)) or '-'} | "
                         f"{cell(', '.join(settings)) or '-'} |")
        parts.append("")

    # [sim]
    rendered.add("sim")
    sim_allowed = {"chips": "`\"fake\"`, `\"real\"`, or a table", "turntable": ", ".join(f'`"{c}"`' for c in
                                                                                          cfg.SIM_CHOICES),
                   "table_link": ", ".join(f'`"{c}"`' for c in cfg.TABLE_LINKS), "faults": "a table"}
    sim_allowed.update({key: allowed for key, (_, _, allowed) in cfg.SIM_WORLD_LIMITS.items()})
    world_comments, world = field_comments(cfg.SimWorld), cfg.SimWorld()
    parts += ["## `[sim]`", "", "Which parts are emulated, the simulated table and its surroundings (what sets one "
              "simulated rig apart from another), and the simulated hardware's faults "
              "([mixed hardware in the loop](../concepts/mixed-hardware.md)).", ""]
    parts += _table([(key, toml_value(getattr(world, key)) if key in cfg.SIM_WORLD_KEYS else "(none)",
                      sim_allowed[key], _meaning("sim", key, world_comments.get(key, ""), used=used))
                     for key in cfg.SECTIONS["sim"]]) + [""]
    fault_rows = []
    comments = field_comments(SimFaults)
    defaults = SimFaults()
    for f in dataclasses.fields(SimFaults):
        value = getattr(defaults, f.name)
        if f.name in _FAULT_RANGES:
            lo, hi, closed = _FAULT_RANGES[f.name]
            allowed = f"{'[' if closed else '('}{number(lo)}, {number(hi)}]"
        elif isinstance(value, tuple):
            allowed = "a list of times, s (>= 0)"
        elif isinstance(value, bool):
            allowed = "true, false"
        elif f.name == "modbus_exception_code":
            allowed = ", ".join(str(c) for c in MODBUS_EXCEPTION_CODES)
        elif isinstance(value, str):
            allowed = "a part of the board" if f.name.endswith("_part") else "a string"
        else:
            allowed = ""
        fault_rows.append((f.name, toml_value(value), allowed, _meaning("sim.faults", f.name,
                                                                         comments.get(f.name, ""), used)))
    doc = inspect.getdoc(SimFaults) or ""
    parts += ["### `[sim.faults]`", "", " ".join(doc.split("\n\n", 1)[-1].split()), ""] + _table(fault_rows) + [""]

    # [store]
    rendered.add("store")
    parts += ["## `[store]`", ""] + _table(
        [(key, "(none)", "a non-empty string", _meaning("store", key, used=used)) for key in cfg.SECTIONS["store"]])
    parts.append("")

    # [[slots]]
    rendered.add("slots")
    comments = field_comments(SlotConfig)
    lo, hi = MUX_ADDRESSES
    slot_rows = {
        "name": ("(required)", "letters, digits, `_`, `-`, `.`; up to 64"),
        "board": ("[unit] board", ", ".join(f"`{name}`" for name in BOARDS)),
        "serial": ('""', "a string"),
        "lever_arm_m": ("[0.0, 0.0, 0.0]", f"three finite numbers, each within +-{number(LEVER_ARM_LIMIT_M)} (m)"),
        "mount_deg": ("(none)", "three finite numbers, each within +-360 (deg)"),
        "i2c_bus": ("[chips] i2c_bus", "a bus number (0, 1, ...)"),
        "spi_bus": ("[chips] spi_bus", "a bus number (0, 1, ...)"),
        "mux": ("(none)", f"`{{address = 0x{lo:02x}..0x{hi:02x}, channel = 0..{MUX_CHANNELS - 1}}}`"),
        "chips": ("(none)", "one table per part, the keys of `[chips.<part>]`"),
    }
    if set(slot_rows) != set(SLOT_KEYS):
        raise Missing(f"[[slots]] keys {sorted(set(SLOT_KEYS) ^ set(slot_rows))}: the page and rig.slot_config differ")
    parts += ["## `[[slots]]`", "",
              "Several boards on one table, recorded in one session ([slots guide](../guides/slots.md)): one "
              "`[[slots]]` table per mounting slot. Without any, the configuration is one unit (`[unit]`). Each slot "
              "is a unit of its own: a session folder per slot under `--out`, beside `slots.json`. Two parts at one "
              "bus location (I2C bus and address, unless behind different channels of a switch; SPI bus and chip "
              "select; GPIO line) are refused.", ""]
    parts += _table([(key, slot_rows[key][0], slot_rows[key][1], comments[key]) for key in SLOT_KEYS]) + [""]

    unrendered = set(cfg.SECTIONS) - rendered
    if unrendered:
        raise Missing(f"sections {sorted(unrendered)} of rig.config.SECTIONS have no table in {__file__}")
    stale = set(MEANINGS) - used
    if stale:
        raise Missing(f"MEANINGS in {__file__} explains keys the code does not read: {sorted(stale)}")
    return "\n".join(parts)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, generate())
    return markdown
