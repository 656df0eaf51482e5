"""Build a rig from its configuration, choosing real or fake per part: this is the only place that does.

By default `rig calibrate --config` builds everything real (the drivers on /dev/i2c-N and /dev/spidevB.C, the
table at `[turntable] url`) and `--sim` everything fake (emulated chips on fake buses, the fake turntable as a
Modbus TCP server on loopback, the simulated world, a virtual clock). A `[sim]` section mixes them:

    [sim]
    chips = "fake"          # or "real", or a table per part: [sim.chips] mag = "fake"
    turntable = "real"      # or "fake"

Emulated chips against a real (or another process's) table follow its polled encoder angles
(`fixtures.followed_table`); real chips against the fake table see a table served in this process. Anything
real runs on the real clock. An analog sensor and the ADC it is read through are emulated together.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field, replace
from typing import Any, Callable

import click

import drivers
from drivers.contract import Wiring
from drivers.errors import DriverError
from drivers.gpio import open_set_reset_line
from drivers.tca9548a import TCA9548A, MuxChannel
from fixtures.followed_table import FollowedTable, PolledTrack
from fixtures.simrig import SimulatedHardware
from fixtures.simslots import SimulatedSlots
from rig.board import SensorBoard, build_board, placements
from rig.bus_budget import CountingI2C, TrafficLog, bus_names, counting_wiring
from rig.clock import Clock, RealClock, SimClock
from rig.config import RigConfig
from rig.errors import InputError, RigError
from rig.turntable import TurntableLink


class AssemblyError(click.ClickException, RigError):
    """The rig cannot be built as configured: one message naming the device or setting, no traceback."""


class BadSetting(AssemblyError, InputError):
    """A setting of the configuration the drivers refuse (exit 2, bad input); named with the file and the part."""


class HardwareUnavailable(AssemblyError):
    """A bus, device node or GPIO line the configuration needs cannot be opened."""


@dataclass
class Rig:
    config: RigConfig
    clock: Clock
    table: Any
    board: SensorBoard
    truth_fn: Any = None
    world: Any = None
    fake_table: Any = None
    sim: Any = None
    _stack: contextlib.ExitStack = field(default_factory=contextlib.ExitStack)

    def close(self) -> None:
        self._stack.close()

    def __enter__(self) -> "Rig":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@dataclass
class SlotsRig:
    """A table carrying several boards (`[[slots]]`): one clock and table, a board per slot (`boards[name]`), each
    with the single-unit configuration its own session records (`configs[name]`) and, simulated, its truth."""

    config: RigConfig
    clock: Clock
    table: Any
    boards: dict[str, SensorBoard]
    configs: dict[str, RigConfig]
    truth_fns: dict[str, Callable[[], dict]] | None = None
    sim: Any = None
    _stack: contextlib.ExitStack = field(default_factory=contextlib.ExitStack)

    def close(self) -> None:
        self._stack.close()

    def __enter__(self) -> "SlotsRig":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def fake_parts(config: RigConfig, simulate: bool) -> set[str]:
    """Names of the board's parts to emulate: all under --sim, none otherwise, unless [sim] chips says."""
    parts = placements(config.board, config.chips)
    choice = config.sim.get("chips", "fake" if simulate else "real")
    if isinstance(choice, str):
        fake = {p.name for p in parts} if choice == "fake" else set()
    else:
        default = "fake" if simulate else "real"
        fake = {p.name for p in parts if choice.get(p.name, default) == "fake"}
    for p in parts:                                   # an analog sensor goes with its ADC
        if p.adc is not None and (p.name in fake or p.adc in fake):
            fake |= {p.name, p.adc}
    return fake


def fake_turntable(config: RigConfig, simulate: bool) -> bool:
    return config.sim.get("turntable", "fake" if simulate else "real") == "fake"


def build_real(config: RigConfig, *, open_i2c=None, open_spi=None, open_gpio=None) -> Rig:
    """The rig on this machine's buses (I2C bus 1, SPI bus 0 unless [chips] says) and the configured table.

    `open_i2c(bus_number)`, `open_spi(bus, device, mode, max_speed_hz)` and `open_gpio(chip_path, line)` default
    to the drivers' helpers (smbus2, spidev, gpiod); a USB bridge adapter (or a test) passes its own.
    """
    return assemble(config, simulate=False, open_i2c=open_i2c, open_spi=open_spi, open_gpio=open_gpio)


def build_sim(config: RigConfig, *, seed: int = 0, trial: int = 0, time_scale: float | None = None,
              effects=(), run: int = 0, clock: Clock | None = None, temperature=None, noise_stream: int = 0) -> Rig:
    """The simulated rig: everything the real one has, emulated, with the truth known.

    `effects` (from `fixtures.world.effects`) are hidden in the world, e.g. to test the discrepancy analysis;
    `run` says which run of a session this is ([sim.faults] timed faults happen in the first only, by default).
    `clock` and `temperature(t)`: a thermal session's, shared with its fake chamber (the die's temperature);
    `noise_stream`: which of a run's noise streams the world draws (a thermal session's steps, each its own).
    """
    return assemble(config, simulate=True, seed=seed, trial=trial, time_scale=time_scale, effects=effects, run=run,
                    clock=clock, temperature=temperature, noise_stream=noise_stream)


def assemble(config: RigConfig, *, simulate: bool, seed: int = 0, trial: int = 0, time_scale: float | None = None,
             effects=(), open_i2c=None, open_spi=None, open_gpio=None, run: int = 0, clock: Clock | None = None,
             temperature=None, noise_stream: int = 0) -> Rig:
    fake = fake_parts(config, simulate)
    table_fake = fake_turntable(config, simulate)
    names = {p.name for p in placements(config.board, config.chips)}
    all_fake = table_fake and fake == names
    if not all_fake and time_scale not in (None, 1.0):
        raise AssemblyError(f"{config.source}: --time-scale needs an all-simulated rig; with a real part "
                                  f"or table ([sim] section) the rig runs on real time")
    if clock is None:
        clock = SimClock(time_scale=time_scale) if all_fake and simulate else RealClock()
    with contextlib.ExitStack() as stack:
        hw = track = None
        if not table_fake and fake:
            track = PolledTrack(delay_s=_follow_delay(config))
        if fake or table_fake:
            hw = SimulatedHardware(config, clock, seed=seed, trial=trial, effects=effects, track=track, only=fake,
                                   run=run, temperature=temperature, noise_stream=noise_stream)
            stack.enter_context(hw)
        wirings = {}
        real = names - fake
        if real:
            real_wiring = _real_wiring(config, clock, stack, real, open_i2c, open_spi, open_gpio)
            wirings.update({name: real_wiring for name in real})
        if fake:
            sim_wiring = hw.board.wiring()
            wirings.update({name: sim_wiring for name in fake})
        try:
            board = build_board(config.board, wirings, chips=config.chips)
        except DriverError as e:
            raise HardwareUnavailable(str(e)) from None
        except ValueError as e:          # was an internal error (exit 70) for [chips.gyro] rate_hz = -50
            raise BadSetting(f"{config.source}: {e}") from None
        link = _link(config, clock, hw.url if table_fake else None)
        stack.enter_context(link)
        table = FollowedTable(link, clock, track) if track is not None else link
        return Rig(config, clock, table, board, truth_fn=hw.truth if fake else None,
                   world=hw.world if fake else None, fake_table=hw.turntable if hw is not None else None, sim=hw,
                   _stack=stack.pop_all())


def assemble_slots(config: RigConfig, *, simulate: bool, seed: int = 0, trial: int = 0,
                   time_scale: float | None = None, effects=(), open_i2c=None, open_spi=None, open_gpio=None,
                   run: int = 0, traffic: Callable[[Clock], TrafficLog] | None = None) -> SlotsRig:
    """The table and every slot's board: all simulated (`simulate`) or all real. `traffic(clock)`, when given, is
    the log every I2C and SPI transfer of every slot is counted into (`rig.bus_budget`'s counting wrappers on
    each bus, above its switch: the selects are counted too)."""
    mixed = [key for key in ("chips", "turntable") if key in config.sim]
    if mixed:
        raise BadSetting(f"{config.source}: [sim] {mixed[0]}: a session of [[slots]] is all simulated (--sim) or "
                         "all real; mixing real and emulated parts is for one unit")
    if not simulate and time_scale not in (None, 1.0):
        raise AssemblyError(f"{config.source}: --time-scale needs the simulated rig")
    clock: Clock = SimClock(time_scale=time_scale) if simulate else RealClock()
    configs = dict(config.slot_configs())
    log = None if traffic is None else traffic(clock)
    counted: dict[int, Any] = {}            # I2C bus number -> its counting wrapper (one per bus)
    switches: dict[tuple[int, int], TCA9548A] = {}       # one driver per switch: its channel cache is the chip's
    with contextlib.ExitStack() as stack:
        hw = None
        if simulate:
            hw = stack.enter_context(SimulatedSlots(config, clock, seed=seed, trial=trial, effects=effects, run=run))
            configs = {name: slot.config for name, slot in hw.slots.items()}
        boards = {}
        opened: dict[int, Any] = {}          # I2C bus number -> the bus opened once for every slot on it
        for slot in config.slots:
            cfg = configs[slot.name]
            if hw is not None:
                wiring = hw.slots[slot.name].board.wiring()
                upstream = hw.i2c[slot.i2c_bus]
            else:
                names = {p.name for p in placements(cfg.board, cfg.chips)}
                wiring = _real_wiring(cfg, clock, stack, names, open_i2c, open_spi, open_gpio, buses=opened)
                upstream = wiring.i2c
            if log is not None:
                wiring = _counted(wiring, upstream, slot, log, counted)
                upstream = counted.get(slot.i2c_bus)
            if slot.mux is not None and upstream is not None:
                address, channel = slot.mux
                switch = switches.get((slot.i2c_bus, address))
                if switch is None:
                    switch = switches[slot.i2c_bus, address] = TCA9548A(upstream, address, sleep=clock.sleep)
                wiring.i2c = MuxChannel(upstream, switch, channel)
            try:
                boards[slot.name] = build_board(cfg.board, wiring, chips=cfg.chips)
            except DriverError as e:
                raise HardwareUnavailable(f"[[slots]] {slot.name}: {e}") from None
            except ValueError as e:
                raise BadSetting(f"{config.source}: [[slots]] {slot.name}: {e}") from None
        link = stack.enter_context(_link(config, clock, hw.url if hw is not None else None))
        truths = None if hw is None else {name: slot.truth for name, slot in hw.slots.items()}
        return SlotsRig(config, clock, link, boards, configs, truths, hw, _stack=stack.pop_all())


def _counted(wiring: Wiring, upstream: Any, slot, log: TrafficLog, counted: dict[int, Any]) -> Wiring:
    """`wiring` of a slot with its I2C bus (the one wrapper of its bus number) and its SPI devices logging into
    `log` under the names `rig plan` gives those buses."""
    i2c_name, spi_name = bus_names({"i2c_bus": slot.i2c_bus, "spi_bus": slot.spi_bus})
    if upstream is not None and slot.i2c_bus not in counted:
        counted[slot.i2c_bus] = CountingI2C(upstream, log, i2c_name)
    out = counting_wiring(wiring, log, i2c_name, spi_name)
    if wiring.i2c is upstream and upstream is not None:
        out = replace(out, i2c=counted[slot.i2c_bus])
    return replace(out, parts=wiring.parts)


def _follow_delay(config: RigConfig) -> float:
    """Two poll intervals: the chips never need an angle not yet polled; the settle time must cover it."""
    delay = 2.0 * config.turntable.poll_every / config.schedule.rate_hz
    if config.turntable.settle_s <= delay:
        raise AssemblyError(
            f"{config.source}: emulated chips following a real table see its motion {delay:.3f} s late (two "
            f"polls); [turntable] settle_s = {config.turntable.settle_s} must exceed that (or lower poll_every)")
    return delay


def _real_wiring(config: RigConfig, clock: Clock, stack: contextlib.ExitStack, real: set[str], open_i2c,
                 open_spi, open_gpio, buses: dict[int, Any] | None = None) -> Wiring:
    open_i2c = open_i2c or drivers.open_i2c
    open_spi = open_spi or drivers.open_spi
    open_gpio = open_gpio or open_set_reset_line
    i2c_bus = int(config.chips.get("i2c_bus", 1))
    spi_bus = int(config.chips.get("spi_bus", 0))

    i2c = None
    if any(p.bus == "i2c" for p in placements(config.board, config.chips) if p.name in real):
        if buses is not None and i2c_bus in buses:      # several slots on one bus share its one handle
            i2c = buses[i2c_bus]
        else:
            i2c = _open(f"I2C bus {i2c_bus} (/dev/i2c-{i2c_bus})", lambda: open_i2c(i2c_bus))
            stack.callback(i2c.close)
            if buses is not None:
                buses[i2c_bus] = i2c

    def spi(cs: int, mode: int, max_hz: int) -> Any:
        dev = _open(f"SPI bus {spi_bus} chip select {cs} (/dev/spidev{spi_bus}.{cs})",
                    lambda: open_spi(spi_bus, cs, mode, max_hz))
        stack.callback(dev.close)
        return dev

    def gpio(chip: str, line: int) -> Callable[[int], None]:
        try:
            strap = open_gpio(chip, line)
        except DriverError as e:
            raise HardwareUnavailable(str(e)) from None
        except ImportError as e:
            raise HardwareUnavailable(f"set/reset GPIO {chip} line {line}: {e}") from None
        stack.callback(getattr(strap, "close", lambda: None))
        return strap

    return Wiring(i2c=i2c, spi=spi, gpio=gpio, sleep=clock.sleep)


def _open(what: str, opener: Callable[[], Any]) -> Any:
    try:
        return opener()
    except FileNotFoundError:
        raise HardwareUnavailable(f"{what}: no such device; enable the bus (e.g. raspi-config), set [chips] "
                                  f"i2c_bus / spi_bus, or emulate the parts on it ([sim] chips = \"fake\" or "
                                  f"rig calibrate --sim)") from None
    except PermissionError:
        raise HardwareUnavailable(f"{what}: permission denied; add the user to the i2c/spi group") from None
    except ImportError as e:
        raise HardwareUnavailable(f"{what}: {e}") from None
    except OSError as e:
        raise HardwareUnavailable(f"{what}: cannot open: {e.strerror or e}") from None


def _link(config: RigConfig, clock: Clock, url: str | None = None) -> TurntableLink:
    rate = config.schedule.rate_hz
    return TurntableLink(url or config.turntable.url, profile=config.turntable.profile, clock=clock,
                         poll_interval=config.turntable.poll_every / rate)


def truth_after_start(rig: Rig) -> dict | None:
    """The simulator's truth in counts; only meaningful once the board started (ranges decide the counts)."""
    return None if rig.truth_fn is None else rig.truth_fn()


def build_rig(config: RigConfig, spec) -> Rig:
    """The rig factory a session orchestrator is given (`procedures.orchestrator.RigFactory`): the simulated rig
    for a simulated spec (its seed, noise trial and time scale), else the real one; a `SlotsRig` for a
    configuration of several slots."""
    if config.slots:
        return assemble_slots(config, simulate=spec.simulated, seed=spec.seed or 0, trial=spec.trial,
                              time_scale=spec.time_scale, run=getattr(spec, "run", 0))
    if spec.simulated:
        return build_sim(config, seed=spec.seed or 0, trial=spec.trial, time_scale=spec.time_scale,
                         run=getattr(spec, "run", 0))
    return build_real(config)
