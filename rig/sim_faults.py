"""[sim.faults]: the faults of the simulated rig's hardware a configuration asks for (`fixtures.fault_plan` injects
them), and their checks: every key, type, range and part named in the refusal."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from rig.board import placements


@dataclass(frozen=True)
class SimFaults:
    """[sim.faults]: faults of the simulated hardware (`fixtures.fault_plan` injects them). Off by default.

    Times are seconds of the rig's clock since the rig was built: a list of instants, each starting one event
    of the kind, lasting the matching `*_s` where it has one. They happen in the run that starts the session;
    with `repeat_on_resume` in every `rig resume` too, timed from its own start. The rates and the delay (the
    quality of the link) hold in every run.
    """

    seed: int = 0                           # draws of the random faults (dropped replies)
    modbus_drop_rate: float = 0.0           # probability that a reply of the fake table is lost
    modbus_delay_s: float = 0.0             # every reply of the fake table late by this many seconds (wall time)
    modbus_exception_at_s: tuple = ()       # the first request after each instant is answered with an exception
    modbus_exception_code: int = 6          # SERVER_DEVICE_BUSY
    turntable_outage_at_s: tuple = ()       # the fake table's Modbus server stops (connections dropped) ...
    turntable_outage_s: float = 1.0         # ... and serves again this long after
    i2c_nack_part: str = ""                 # the part on I2C that NACKs every transfer ...
    i2c_nack_at_s: tuple = ()
    i2c_nack_s: float = 0.05
    adxrs453_axis: str = "x"                # the ADXRS453 (x, y or z) that ...
    adxrs453_parity_at_s: tuple = ()        # ... answers with P1 parity errors ...
    adxrs453_parity_s: float = 0.05
    adxrs453_fault_at_s: tuple = ()         # ... or asserts FAULT bits
    adxrs453_fault_s: float = 0.05
    adxrs453_fault_bits: int = 0x0100       # UV (under-voltage)
    chip_reset_part: str = ""               # the part that resets to its power-on registers ...
    chip_reset_at_s: tuple = ()
    bump_at_s: tuple = ()                   # a knock on the table during the first hold after each instant
    bump_amplitude_deg: float = 0.3
    repeat_on_resume: bool = False          # the timed faults (*_at_s) happen again in every resumed run

    def any(self) -> bool:
        return self != SimFaults(seed=self.seed)


MODBUS_EXCEPTION_CODES = (1, 2, 3, 4, 5, 6, 8, 10, 11)
_FAULT_RANGES = {  # key: (lowest, highest, lowest allowed itself)
    "seed": (0, 2 ** 63, True), "modbus_drop_rate": (0.0, 0.5, True), "modbus_delay_s": (0.0, 2.0, True),
    "turntable_outage_s": (0.0, 600.0, False), "i2c_nack_s": (0.0, 600.0, False),
    "adxrs453_parity_s": (0.0, 600.0, False), "adxrs453_fault_s": (0.0, 600.0, False),
    "bump_amplitude_deg": (0.0, 10.0, False), "adxrs453_fault_bits": (2, 0x0FFE, True)}


def checked_sim_faults(sim: dict, source: str, board: str, chips: dict) -> SimFaults:
    """A configuration's [sim.faults] (of its [sim] table `sim`, file `source`), checked: unknown keys, wrong types,
    out-of-range values, parts the board has not (or that cannot have the fault) are errors naming the key."""
    raw = sim.get("faults", {})
    if not isinstance(raw, dict):
        raise ValueError(f"{source}: [sim] faults = {raw!r} must be a table ([sim.faults])")
    known = {f.name: f for f in fields(SimFaults)}
    unknown = set(raw) - set(known)
    if unknown:
        raise ValueError(f"{source}: [sim.faults] has unknown keys {sorted(unknown)}; allowed: {sorted(known)}")
    values = {}
    for key, value in raw.items():
        where = f"{source}: [sim.faults] {key} = {value!r}"
        default = known[key].default
        if isinstance(default, tuple):
            if not isinstance(value, (list, tuple)) or not all(is_finite_number(v) and v >= 0 for v in value):
                raise ValueError(f"{where} must be a list of times in seconds (finite, >= 0)")
            value = tuple(sorted(float(v) for v in value))
        elif isinstance(default, bool):
            if not isinstance(value, bool):
                raise ValueError(f"{where} must be true or false")
        elif isinstance(default, str):
            if not isinstance(value, str):
                raise ValueError(f"{where} must be a string")
        elif isinstance(default, int):
            if isinstance(value, bool) or not isinstance(value, int):
                raise ValueError(f"{where} must be a whole number")
        elif not is_finite_number(value):
            raise ValueError(f"{where} must be a finite number")
        if key in _FAULT_RANGES:
            lo, hi, closed = _FAULT_RANGES[key]
            if not (lo <= value <= hi and (closed or value > lo)):
                raise ValueError(f"{where} is out of range {'[' if closed else '('}{lo:g}, {hi:g}]")
        values[key] = float(value) if isinstance(default, float) and not isinstance(default, bool) else value
    faults = SimFaults(**values)
    _check_fault_parts(faults, source, board, chips)
    return faults


def is_finite_number(value) -> bool:
    """A number (not a bool) that is finite."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_fault_parts(faults: SimFaults, source: str, board: str, chips: dict) -> None:
    where = f"{source}: [sim.faults]"
    parts = {p.name: p for p in placements(board, chips)}
    if faults.modbus_exception_code not in MODBUS_EXCEPTION_CODES:
        raise ValueError(f"{where} modbus_exception_code = {faults.modbus_exception_code}; Modbus exception codes: "
                         f"{list(MODBUS_EXCEPTION_CODES)}")
    if faults.i2c_nack_at_s or faults.i2c_nack_part:
        part = parts.get(faults.i2c_nack_part)
        if part is None or part.bus != "i2c":
            on_i2c = [name for name, p in parts.items() if p.bus == "i2c"]
            raise ValueError(f"{where} i2c_nack_part = {faults.i2c_nack_part!r} must name a part on I2C of the "
                             f"{board} board: {on_i2c}")
    if faults.chip_reset_at_s or faults.chip_reset_part:
        part = parts.get(faults.chip_reset_part)
        if part is None or part.bus == "adc" or part.chip == "MCP3208":
            with_registers = [n for n, p in parts.items() if p.bus != "adc" and p.chip != "MCP3208"]
            raise ValueError(f"{where} chip_reset_part = {faults.chip_reset_part!r} must name a chip with registers "
                             f"on the {board} board: {with_registers}")
    if faults.adxrs453_axis not in ("x", "y", "z"):
        raise ValueError(f"{where} adxrs453_axis = {faults.adxrs453_axis!r}; allowed: x, y, z")
    if (faults.adxrs453_parity_at_s or faults.adxrs453_fault_at_s) \
            and not any(p.chip == "ADXRS453 triad" for p in parts.values()):
        raise ValueError(f"{where} adxrs453_*: the {board} board has no ADXRS453")
