"""Rig configuration (TOML): the board, the turntable, the table geometry, the schedule, G and M, limits.

The same file describes a real rig and, with `--sim`, the simulated one built from the fakes; the choice
between real and fake is made in `rig.assembly`, never inside a driver.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass, field, fields
from importlib import resources
from pathlib import Path

from rig.board import placements
from rig.boards import BOARDS as BOARD_SPECS
from rig.report.limits import LimitsError, validate_limits
from rig.io.text_file import read_utf8
from rig.rotations import TableGeometry
from rig.sim_faults import SimFaults, checked_sim_faults, is_finite_number
from rig.slot_config import SlotConfig, parse_slots, slot_config, slots_from_dicts
from rig.chamber.profile import load_profile as load_chamber_profile
from rig.turntable.profile import load_profile

BOARDS = tuple(BOARD_SPECS)
SIM_CHOICES = ("fake", "real")
TABLE_LINKS = ("tcp", "rtu-tcp", "rtu-pty")   # the fake table's line: Modbus TCP, RTU via a gateway, RTU on a serial line


@dataclass
class TurntableConfig:
    url: str = "tcp://127.0.0.1:502"
    profile: str | None = None
    speed_dps: float = 60.0
    accel_dps2: float = 120.0
    tolerance_deg: float = 0.01
    settle_s: float = 0.3
    poll_every: int = 10               # encoder/status poll every N sample ticks during moves
    watchdog_ms: int = 2000            # the table stops by itself if the rig goes quiet this long (0: off)


@dataclass
class ChamberConfig:
    """[chamber]: the thermal chamber's controller (docs/reference/configuration.md, docs/guides/chamber.md)."""
    url: str = "tcp://127.0.0.1:502"
    profile: str | None = None         # chamber register profile; default: the packaged Watlow F4T one
    tolerance_c: float = 0.5           # the air is at its set point within this
    soak_timeout_s: float = 3600.0     # a set point not reached in this long is a fault
    ramp_c_per_min: float = 2.0        # 0: set points step
    timeout_s: float = 1.0             # per Modbus request
    poll_s: float = 2.0                # between readings of the air while waiting


@dataclass
class ThermalConfig:
    """[thermal]: a thermal session's temperature steps, its soaks and each step's table schedule
    (docs/guides/thermal-session.md). Set points are `steps_c`, or `steps` evenly from `low_c` to `high_c`;
    `direction` "up", "down" or "up-down" (up, then down through the same points, the hottest once)."""
    steps_c: list = field(default_factory=list)
    low_c: float = 5.0
    high_c: float = 45.0
    steps: int = 3
    direction: str = "up-down"
    slope_c_per_min: float = 0.1       # soaked: the die's slope over `window_s` below this, C/min
    window_s: float = 60.0             # the die temperature's slope is fitted over this much of the chips' readings
    poll_s: float = 5.0                # between readings of the chips' thermometers while soaking
    min_soak_s: float = 120.0          # never soaked sooner than this after the set point is written
    max_soak_s: float = 7200.0         # not soaked in this long: a fault (the chamber or the fixture)
    orientations: int = 0              # each step's schedule size; 0: [schedule] orientations
    hold_s: float = 0.0                # each step's hold; 0: [schedule] hold_s
    step_H_std_pct: float = 0.0        # with orientations 0: the planner's shortest schedule predicting this H error
    sim_hysteresis: bool = False       # the simulated unit carries a hysteresis between up and down sweeps
    ramp_c_per_min: float = 0.0        # >0: a ramped step on each move between set points, C/min; 0: all soaked
    sim_lag_s: float = 0.0             # the simulated unit's sensing elements lag its die thermometer by this, s


THERMAL_DIRECTIONS = ("up", "down", "up-down")


@dataclass
class ScheduleConfig:
    orientations: int = 20
    hold_s: float = 5.0
    rate_hz: float = 100.0
    mag_every: int = 2
    max_hold_attempts: int = 3
    sequential: bool = False           # sequential holds (procedures.hold_quality.HoldTarget)
    hold_min_s: float = 1.5            # their shortest hold (bump detection judges three 0.5 s windows)
    hold_max_s: float = 0.0            # their longest; 0: three times hold_s
    mount_s: float = 300.0             # seconds to take a session's units off the table and mount the next ones


@dataclass
class RigConfig:
    serial: str = "UNKNOWN"
    board: str = "bsn"
    operator: str = ""
    turntable: TurntableConfig = field(default_factory=TurntableConfig)
    geometry: TableGeometry = field(default_factory=TableGeometry)
    schedule: ScheduleConfig = field(default_factory=ScheduleConfig)
    gravity_mps2: float = 9.80665
    field_uT: float = 50.0
    limits: dict = field(default_factory=dict)
    chips: dict = field(default_factory=dict)      # [chips]: buses and per-part overrides of the board's placements
    sim: dict = field(default_factory=dict)        # [sim]: which parts are emulated ("fake") or real
    store: dict = field(default_factory=dict)      # [store] url (the lab's store), rig (this rig's name in it)
    chamber: ChamberConfig | None = None           # [chamber]; None: no chamber on this rig
    thermal: ThermalConfig | None = None           # [thermal]; None: sessions at one temperature
    source: str = "<defaults>"
    slots: tuple[SlotConfig, ...] = ()             # [[slots]]: several boards on the table; none: one unit

    def to_dict(self) -> dict:
        d = asdict(self)
        d["geometry"] = self.geometry.to_dict()
        if self.slots:
            d["slots"] = [s.to_dict() for s in self.slots]
        else:
            del d["slots"]          # a one-unit configuration's snapshot is what it always was
        return d

    def slot_configs(self) -> dict[str, "RigConfig"]:
        """Slot name -> the single-unit configuration its own session records (`rig.slot_config.slot_config`)."""
        return {s.name: slot_config(self, s) for s in self.slots}


def load_config(path: str | Path | None = None) -> RigConfig:
    """Read a rig TOML file; with no path, the built-in simulated rig's configuration."""
    if path is None:
        text, where = resources.files("rig.configs").joinpath("sim.toml").read_text(), "<built-in sim.toml>"
    else:
        where = str(path)
        text = read_utf8(Path(path), lambda message, line: ValueError(
            f"{where}" + (f", line {line}" if line else "") + f": cannot read rig configuration: {message}"))
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{where}: not valid TOML: {e}") from None
    config = _from_dict(raw, where)
    profile = config.turntable.profile
    if path is not None and profile and not Path(profile).is_absolute():
        config.turntable.profile = str(Path(path).parent / profile)     # beside the file that names it
    if profile:
        # read here, so a missing or malformed register map is bad input before anything is created, not a fault
        # of the turntable once the session has started
        try:
            load_profile(config.turntable.profile)
        except ValueError as e:
            raise ValueError(f"{where}: [turntable] profile = {profile!r} (a path relative to this configuration): "
                             f"{e}") from None
    _check_chamber_profile(config, path, where)
    return config


def _check_chamber_profile(config: RigConfig, path: str | Path | None, where: str) -> None:
    """[chamber] profile, resolved beside the configuration and read now, as the turntable's is; a thermal
    session's ramp within its limit."""
    profile = config.chamber.profile if config.chamber is not None else None
    if not profile:
        _check_ramps(config, where)
        return
    if path is not None and not Path(profile).is_absolute():
        config.chamber.profile = str(Path(path).parent / profile)
    try:
        load_chamber_profile(config.chamber.profile)
    except ValueError as e:
        raise ValueError(f"{where}: [chamber] profile = {profile!r} (a path relative to this configuration): "
                         f"{e}") from None
    _check_ramps(config, where)


def _check_ramps(config: RigConfig, where: str) -> None:
    """[thermal] ramp_c_per_min within the chamber profile's `max_ramp_c_per_min`."""
    if config.chamber is None or config.thermal is None or not config.thermal.ramp_c_per_min:
        return
    top = load_chamber_profile(config.chamber.profile).max_ramp_c_per_min
    if config.thermal.ramp_c_per_min > top:
        raise ValueError(f"{where}: [thermal] ramp_c_per_min = {config.thermal.ramp_c_per_min!r} is beyond the "
                         f"chamber's {top:g} C/min (its profile's max_ramp_c_per_min)")


@dataclass(frozen=True)
class SimWorld:
    """[sim] keys of the simulated rig's own table and surroundings: what sets one simulated rig apart from another,
    put into its simulated world by `fixtures.simrig`. All zero: an ideal table in the plain geomagnetic field."""

    table_zero_deg: tuple = (0.0, 0.0)          # the table's true encoder zeros off [table]'s (outer, inner), deg
    table_tilt_deg: tuple = (0.0, 0.0, 0.0)     # inner axis tilted off square to the outer, rotation vector, deg
    table_field_uT: tuple = (0.0, 0.0, 0.0)     # a field the table carries, in the outer gimbal's frame, uT
    fixture_play_deg: float = 0.0               # a loose holder: the unit seated turned by up to +- this each session


SIM_WORLD_KEYS = tuple(f.name for f in fields(SimWorld))
# key: (how many numbers, largest magnitude of each, what the page of configuration keys says is allowed)
SIM_WORLD_LIMITS = {
    "table_zero_deg": (2, 5.0, "two finite numbers, each within +-5 (deg)"),
    "table_tilt_deg": (3, 5.0, "three finite numbers, each within +-5 (deg)"),
    "table_field_uT": (3, 100.0, "three finite numbers, each within +-100 (uT)"),
    "fixture_play_deg": (None, 10.0, "a finite number, 0 to 10 (deg)"),
}

SECTIONS = {"unit": ("serial", "board", "operator"),
            "table": ("outer_axis_world", "inner_axis_fixture", "outer_zero_deg", "inner_zero_deg"),
            "environment": ("gravity_mps2", "field_uT"),
            "turntable": None, "schedule": None, "limits": None, "chips": None,
            "sim": ("chips", "turntable", "table_link", "faults", *SIM_WORLD_KEYS), "store": ("url", "rig"),
            "chamber": None, "thermal": None, "slots": None}
ARRAYS = ("slots",)         # arrays of tables ([[slots]]), checked by their own reader


def _check_keys(raw: dict, where: str) -> None:
    """Unknown sections and keys are errors: a misspelt key silently ignored is a wrong calibration."""
    unknown = set(raw) - set(SECTIONS)
    if unknown:
        raise ValueError(f"{where}: unknown sections {sorted(unknown)}; allowed: {sorted(SECTIONS)}")
    for name in SECTIONS:        # `unit = "x"` instead of a [unit] table: its characters were read as its keys
        if name in raw and name not in ARRAYS and not isinstance(raw[name], dict):
            raise ValueError(f"{where}: {name} = {raw[name]!r} must be a table (a [{name}] section)")
    for name, keys in SECTIONS.items():
        if keys is not None and not set(raw.get(name, {})) <= set(keys):
            raise ValueError(f"{where}: [{name}] has unknown keys {sorted(set(raw[name]) - set(keys))}; "
                             f"allowed: {sorted(keys)}")


def _section(raw: dict, name: str, cls, where: str):
    data = raw.get(name, {})
    known = set(cls.__dataclass_fields__)
    unknown = set(data) - known
    if unknown:
        raise ValueError(f"{where}: [{name}] has unknown keys {sorted(unknown)}; allowed: {sorted(known)}")
    defaults = cls()
    for key, value in data.items():
        default = getattr(defaults, key)
        numeric = isinstance(default, (int, float)) and not isinstance(default, bool)
        if numeric and (isinstance(value, bool) or not isinstance(value, (int, float))):
            raise ValueError(f"{where}: [{name}] {key} = {value!r} must be a number")
        if numeric and not math.isfinite(value):
            raise ValueError(f"{where}: [{name}] {key} = {value!r} must be a finite number")
        if isinstance(default, int) and not isinstance(default, bool) and isinstance(value, float) \
                and not value.is_integer():
            raise ValueError(f"{where}: [{name}] {key} = {value!r} must be a whole number")
        if (isinstance(default, str) or default is None) and not isinstance(value, str):
            # a number where a URL or a profile name belongs would otherwise reach the turntable client
            raise ValueError(f"{where}: [{name}] {key} = {value!r} must be a string")
        if numeric and (name, key) in RANGES:
            lo, hi, why = RANGES[name, key]
            if not lo <= value <= hi:
                raise ValueError(f"{where}: [{name}] {key} = {value!r} must be in {lo:g}..{hi:g} ({why})")
    try:
        return cls(**data)
    except TypeError as e:
        raise ValueError(f"{where}: [{name}]: {e}") from None


# Ranges a rig can run, checked where the file is read. Outside them the session failed deep inside (mag_every = 0:
# a ZeroDivisionError after the session was created, exit 70), ran without sense (settle_s = -1, hold_s = 0.01:
# one sample a hold, verdict PASS), or `rig plan` itself ran out of memory (speed_dps = 0.001,
# settle_s = 1e6: the moves sampled for hours) or crashed (hold_s = 1e308).
RANGES = {  # (section, key): (lowest, highest, why)
    ("schedule", "hold_s"): (0.1, 3600.0, "seconds; 1.5 or more lets bump detection judge three 0.5 s windows"),
    ("schedule", "rate_hz"): (1.0, 1000.0, "the sample grid, Hz"),
    ("schedule", "mag_every"): (1, 1000, "the magnetometer is read every N-th sample"),
    ("schedule", "max_hold_attempts"): (1, 100, "tries of a hold that shows motion"),
    ("schedule", "hold_min_s"): (0.0, 3600.0, "seconds"),
    ("schedule", "hold_max_s"): (0.0, 36000.0, "seconds; 0: three times hold_s"),
    ("schedule", "mount_s"): (0.0, 86400.0, "seconds between sessions to swap units"),
    ("turntable", "speed_dps"): (0.1, 10000.0, "deg/s"),
    ("turntable", "accel_dps2"): (0.1, 1e6, "deg/s^2"),
    ("turntable", "tolerance_deg"): (1e-6, 1.0, "the in-position window, deg"),
    ("turntable", "settle_s"): (0.0, 60.0, "seconds in position before a hold"),
    ("turntable", "poll_every"): (1, 10000, "sample ticks between status polls during moves"),
    ("turntable", "watchdog_ms"): (0, 65535, "ms; 0: off"),
    ("chamber", "tolerance_c"): (0.01, 20.0, "C"),
    ("chamber", "soak_timeout_s"): (1.0, 86400.0, "seconds"),
    ("chamber", "ramp_c_per_min"): (0.0, 100.0, "C/min; 0: step"),
    ("chamber", "timeout_s"): (0.01, 600.0, "seconds per request"),
    ("chamber", "poll_s"): (0.01, 600.0, "seconds"),
    ("thermal", "low_c"): (-100.0, 250.0, "C"),
    ("thermal", "high_c"): (-100.0, 250.0, "C"),
    ("thermal", "steps"): (2, 100, "set points from low_c to high_c"),
    ("thermal", "slope_c_per_min"): (1e-4, 10.0, "C/min"),
    ("thermal", "window_s"): (1.0, 3600.0, "seconds"),
    ("thermal", "poll_s"): (0.01, 600.0, "seconds"),
    ("thermal", "min_soak_s"): (0.0, 86400.0, "seconds"),
    ("thermal", "max_soak_s"): (1.0, 172800.0, "seconds"),
    ("thermal", "orientations"): (0, 64, "0: [schedule] orientations; else 9..64"),
    ("thermal", "hold_s"): (0.0, 3600.0, "seconds; 0: [schedule] hold_s"),
    ("thermal", "step_H_std_pct"): (0.0, 100.0, "percent; 0: no planning"),
    ("thermal", "ramp_c_per_min"): (0.0, 10.0, "C/min; 0: every step soaked; else above twice slope_c_per_min"),
    ("thermal", "sim_lag_s"): (0.0, 3600.0, "seconds; 0: no lag"),
}


def _positive(section: dict, key: str, default: float, where: str) -> float:
    value = section.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
        raise ValueError(f"{where}: [environment] {key} = {value!r} must be a positive finite number")
    return float(value)


def _axis(table: dict, key: str, default: tuple, where: str) -> tuple[float, float, float]:
    """A [table] axis: three finite numbers, not all zero. A scalar crashed (exit 70), a string gave a message
    naming neither file nor key, and a zero or NaN axis made every orientation NaN (exit 3, "schedule")."""
    value = table.get(key, default)
    if not (isinstance(value, (list, tuple)) and len(value) == 3 and all(is_finite_number(v) for v in value)
            and any(v != 0 for v in value)):
        raise ValueError(f"{where}: [table] {key} = {value!r} must be a direction: three finite numbers, "
                         "not all zero (e.g. [1, 0, 0])")
    return tuple(float(v) for v in value)


def _finite_number(table: dict, key: str, where: str) -> float:
    value = table.get(key, 0.0)
    if not is_finite_number(value):
        raise ValueError(f"{where}: [table] {key} = {value!r} must be a finite number (degrees)")
    return float(value)


def _from_dict(raw: dict, where: str) -> RigConfig:
    _check_keys(raw, where)
    unit = raw.get("unit", {})
    board = unit.get("board", "bsn")
    if board not in BOARDS:
        raise ValueError(f"{where}: [unit] board = {board!r}; allowed: {list(BOARDS)}")
    table = raw.get("table", {})
    geometry = TableGeometry(
        outer_axis_world=_axis(table, "outer_axis_world", (1.0, 0.0, 0.0), where),
        inner_axis_fixture=_axis(table, "inner_axis_fixture", (0.0, 0.0, 1.0), where),
        outer_zero_deg=_finite_number(table, "outer_zero_deg", where),
        inner_zero_deg=_finite_number(table, "inner_zero_deg", where))
    env = raw.get("environment", {})
    cfg = RigConfig(serial=str(unit.get("serial", "UNKNOWN")), board=board, operator=str(unit.get("operator", "")),
                    turntable=_section(raw, "turntable", TurntableConfig, where), geometry=geometry,
                    schedule=_section(raw, "schedule", ScheduleConfig, where),
                    gravity_mps2=_positive(env, "gravity_mps2", 9.80665, where),
                    field_uT=_positive(env, "field_uT", 50.0, where),
                    limits=dict(raw.get("limits", {})), chips=dict(raw.get("chips", {})),
                    sim=dict(raw.get("sim", {})), store=dict(raw.get("store", {})), source=where)
    cfg.chamber = _section(raw, "chamber", ChamberConfig, where) if "chamber" in raw else None
    cfg.thermal = _thermal(raw, where) if "thermal" in raw else None
    cfg.slots = parse_slots(raw.get("slots"), unit_board=board, chips=cfg.chips, where=where)
    for key, value in cfg.store.items():
        if not isinstance(value, str) or not value:
            raise ValueError(f"{where}: [store] {key} = {value!r} must be a non-empty string")
    try:
        placements(cfg.board, cfg.chips)
        check_sim(cfg.board, cfg.sim)
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None
    sim_faults(cfg)                  # names the file itself (it was named twice)
    if not 9 <= cfg.schedule.orientations <= 64:
        raise ValueError(f"{where}: [schedule] orientations = {cfg.schedule.orientations}; use 10 to 20 "
                         "(9..64 allowed: the ellipsoid needs 9)")
    if cfg.schedule.max_hold_attempts < 1 or cfg.turntable.poll_every < 1:
        raise ValueError(f"{where}: [schedule] max_hold_attempts and [turntable] poll_every must be at least 1")
    for key in ("speed_dps", "accel_dps2", "tolerance_deg"):
        if not getattr(cfg.turntable, key) > 0:
            raise ValueError(f"{where}: [turntable] {key} must be positive")
    if cfg.schedule.hold_s <= 0 or cfg.schedule.rate_hz <= 0:
        raise ValueError(f"{where}: [schedule] hold_s and rate_hz must be positive")
    s = cfg.schedule
    if not isinstance(s.sequential, bool):
        raise ValueError(f"{where}: [schedule] sequential = {s.sequential!r} must be true or false")
    if s.sequential and (not 0 < s.hold_min_s <= s.hold_s or not (s.hold_max_s == 0 or s.hold_max_s >= s.hold_s)):
        raise ValueError(f"{where}: [schedule] hold_min_s = {s.hold_min_s} must be in (0, hold_s] and hold_max_s = "
                         f"{s.hold_max_s} 0 (three times hold_s) or at least hold_s = {s.hold_s}")
    try:
        validate_limits(cfg.limits)
    except LimitsError as e:
        raise ValueError(f"{where}: [limits] {e}") from None
    for board in {cfg.board, *(s.board for s in cfg.slots)}:
        sensors = sorted(BOARD_SPECS[board].triads)
        for sensor in cfg.limits:    # [limits.acel]: its limits were never checked and the verdict said PASS
            if sensor not in sensors:
                raise ValueError(f"{where}: [limits.{sensor}]: no such sensor; the {board} board has {sensors}")
    if cfg.slots:
        _check_slots(cfg, where)
    return cfg


def _thermal(raw: dict, where: str) -> ThermalConfig:
    """[thermal], its lists and choices checked beside the numbers `_section` checks."""
    t = _section(raw, "thermal", ThermalConfig, where)
    if not (isinstance(t.steps_c, list) and all(is_finite_number(v) for v in t.steps_c)):
        raise ValueError(f"{where}: [thermal] steps_c = {t.steps_c!r} must be a list of temperatures in C")
    t.steps_c = [float(v) for v in t.steps_c]
    if t.steps_c and len(set(t.steps_c)) < 2:
        raise ValueError(f"{where}: [thermal] steps_c = {t.steps_c!r}: a temperature model needs 2 or more "
                         "distinct set points")
    if not t.steps_c and not t.low_c < t.high_c:
        raise ValueError(f"{where}: [thermal] low_c = {t.low_c!r} must be below high_c = {t.high_c!r}")
    if t.direction not in THERMAL_DIRECTIONS:
        raise ValueError(f"{where}: [thermal] direction = {t.direction!r}; allowed: {list(THERMAL_DIRECTIONS)}")
    if not isinstance(t.sim_hysteresis, bool):
        raise ValueError(f"{where}: [thermal] sim_hysteresis = {t.sim_hysteresis!r} must be true or false")
    if t.orientations and t.orientations < 9:
        raise ValueError(f"{where}: [thermal] orientations = {t.orientations}: 0 ([schedule]'s) or 9..64")
    if t.max_soak_s < t.min_soak_s:
        raise ValueError(f"{where}: [thermal] max_soak_s = {t.max_soak_s!r} is below min_soak_s = {t.min_soak_s!r}")
    if t.ramp_c_per_min and not t.ramp_c_per_min > 2 * t.slope_c_per_min:
        raise ValueError(f"{where}: [thermal] ramp_c_per_min = {t.ramp_c_per_min!r} must be 0 (every step soaked) "
                         f"or above twice slope_c_per_min = {t.slope_c_per_min!r}: a ramped step's die moves at the "
                         "ramp's rate within slope_c_per_min, a soaked step's within slope_c_per_min of standing "
                         "still, and the two must not overlap")
    return t


def thermal_set_points(t: ThermalConfig) -> list[float]:
    """The set points of a thermal session in the order they are visited (`ThermalConfig`)."""
    points = sorted(set(t.steps_c)) if t.steps_c else [float(v) for v in
                                                 [t.low_c + (t.high_c - t.low_c) * k / (t.steps - 1)
                                                  for k in range(t.steps)]]
    if t.direction == "down":
        return points[::-1]
    if t.direction == "up-down":
        return points + points[-2::-1]
    return points


def thermal_steps(t: ThermalConfig) -> list[tuple[float, float]]:
    """The steps of a thermal session in the order they run, as (temperature C, ramp C/min): a soaked step at each
    set point (`thermal_set_points`, ramp 0) and, with `ramp_c_per_min`, a ramped step on each move between two
    set points, centred halfway between them, its ramp signed with the move (rising positive)."""
    points = thermal_set_points(t)
    out = [(points[0], 0.0)]
    for a, b in zip(points, points[1:]):
        if t.ramp_c_per_min and a != b:
            out.append((0.5 * (a + b), math.copysign(t.ramp_c_per_min, b - a)))
        out.append((b, 0.0))
    return out


def _check_slots(cfg: RigConfig, where: str) -> None:
    """What a session of several slots does not do (yet): refused before anything is built."""
    if cfg.schedule.sequential:
        raise ValueError(f"{where}: [schedule] sequential = true: sequential holds end on one unit's noise; a "
                         "session of [[slots]] holds every orientation hold_s")
    if cfg.sim.get("faults"):
        raise ValueError(f"{where}: [sim.faults] names the parts of one board; with [[slots]] it is not supported")
    for slot in cfg.slots:
        try:
            check_sim(slot.board, cfg.sim)
        except ValueError as e:
            raise ValueError(f"{where}: [[slots]] {slot.name}: {e}") from None


def config_from_dict(d: dict) -> RigConfig:
    """Rebuild a configuration from its `to_dict()` snapshot (session metadata)."""
    g = d.get("geometry", {})
    geometry = TableGeometry(tuple(g.get("outer_axis_world", (1, 0, 0))), tuple(g.get("inner_axis_fixture", (0, 0, 1))),
                             float(g.get("outer_zero_deg", 0.0)), float(g.get("inner_zero_deg", 0.0)),
                             tuple(g.get("inner_tilt_deg", (0, 0, 0))))
    return RigConfig(serial=d.get("serial", "UNKNOWN"), board=d.get("board", "bsn"), operator=d.get("operator", ""),
                     turntable=TurntableConfig(**d.get("turntable", {})), geometry=geometry,
                     schedule=ScheduleConfig(**d.get("schedule", {})), gravity_mps2=d.get("gravity_mps2", 9.80665),
                     field_uT=d.get("field_uT", 50.0), limits=d.get("limits", {}), chips=d.get("chips", {}),
                     sim=d.get("sim", {}), store=d.get("store", {}), source=d.get("source", "<session metadata>"),
                     chamber=ChamberConfig(**d["chamber"]) if d.get("chamber") else None,
                     thermal=ThermalConfig(**d["thermal"]) if d.get("thermal") else None,
                     slots=slots_from_dicts(d.get("slots") or []))


def check_sim(board: str, sim: dict) -> None:
    """[sim] chips = "fake" | "real" | {part = "fake" | "real"}, turntable = "fake" | "real",
    table_link = "tcp" | "rtu-tcp" | "rtu-pty" (how the rig reaches the fake table), and the keys of `SimWorld`."""
    checked_sim_world(sim)
    table = sim.get("turntable")
    if table is not None and table not in SIM_CHOICES:
        raise ValueError(f"[sim] turntable = {table!r}; allowed: {list(SIM_CHOICES)}")
    link = sim.get("table_link")
    if link is not None and link not in TABLE_LINKS:
        raise ValueError(f"[sim] table_link = {link!r}; allowed: {list(TABLE_LINKS)}")
    chips = sim.get("chips")
    if chips is None or chips in SIM_CHOICES:
        return
    if not isinstance(chips, dict):
        raise ValueError(f"[sim] chips = {chips!r}; allowed: {list(SIM_CHOICES)} or a table part = \"fake\"|\"real\"")
    names = BOARD_SPECS[board].names
    for part, choice in chips.items():
        if part not in names:
            raise ValueError(f"[sim.chips] {part}: the {board} board has no such part; parts: {list(names)}")
        if choice not in SIM_CHOICES:
            raise ValueError(f"[sim.chips] {part} = {choice!r}; allowed: {list(SIM_CHOICES)}")
    for p in BOARD_SPECS[board].parts:  # an analog sensor and its ADC are emulated together (rig.assembly)
        if p.adc is not None and p.name in chips and p.adc in chips and chips[p.name] != chips[p.adc]:
            # one of the two silently became what the user said it was not
            raise ValueError(f"[sim.chips] {p.name} = {chips[p.name]!r} but {p.adc} = {chips[p.adc]!r}: {p.name} "
                             f"({p.chip}) is read through {p.adc}, so both are real or both fake")


def checked_sim_world(sim: dict) -> SimWorld:
    """The `SimWorld` keys of a [sim] table, checked: numbers, how many, and their size (`SIM_WORLD_LIMITS`)."""
    values = {}
    for key in SIM_WORLD_KEYS:
        if key not in sim:
            continue
        value = sim[key]
        count, largest, allowed = SIM_WORLD_LIMITS[key]
        items = value if count is not None and isinstance(value, (list, tuple)) else [value]
        good = (all(is_finite_number(v) and abs(v) <= largest for v in items)
                and (len(items) == count if count is not None else not isinstance(value, (list, tuple)) and value >= 0))
        if not good:
            raise ValueError(f"[sim] {key} = {value!r} must be {allowed}")
        values[key] = tuple(float(v) for v in items) if count is not None else float(value)
    return SimWorld(**values)


def sim_world(config: RigConfig) -> SimWorld:
    """The configuration's simulated table and surroundings (`SimWorld`), checked."""
    try:
        return checked_sim_world(config.sim)
    except ValueError as e:
        raise ValueError(f"{config.source}: {e}") from None


def sim_faults(config: RigConfig) -> SimFaults:
    """The configuration's [sim.faults], checked (`rig.sim_faults`)."""
    return checked_sim_faults(config.sim, config.source, config.board, config.chips)
