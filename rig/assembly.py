"""Build a rig from its configuration: the real one on real buses and a real table, or (`--sim`) the same
rig from the fakes: emulated chips on fake buses, the fake turntable as a Modbus TCP server on loopback,
the simulated world and a virtual clock. This is the only place that chooses between real and fake.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from typing import Any

from rig.board import SensorBoard, build_board
from rig.clock import Clock, RealClock, SimClock
from rig.config import RigConfig
from rig.turntable import TurntableLink


@dataclass
class Rig:
    config: RigConfig
    clock: Clock
    table: Any
    board: SensorBoard
    truth_fn: Any = None
    world: Any = None
    fake_table: Any = None
    _stack: contextlib.ExitStack = field(default_factory=contextlib.ExitStack)

    def close(self) -> None:
        self._stack.close()

    def __enter__(self) -> "Rig":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def build_real(config: RigConfig, *, open_i2c=None, open_spi=None) -> Rig:
    """The rig on this machine's buses (I2C bus 1, SPI bus 0) and the configured turntable URL.

    `open_i2c(bus_number)` and `open_spi(bus, device, mode, max_speed_hz)` default to the drivers' helpers
    (smbus2, spidev); a USB bridge adapter (or a test) passes its own.
    """
    import drivers

    open_i2c = open_i2c or drivers.open_i2c
    open_spi = open_spi or drivers.open_spi
    clock = RealClock()
    stack = contextlib.ExitStack()
    bus = open_i2c(int(config.chips.get("i2c_bus", 1)))
    stack.callback(bus.close)
    spi_bus = int(config.chips.get("spi_bus", 0))

    def spi(cs: int, mode: int, max_hz: int):
        dev = open_spi(spi_bus, cs, mode, max_hz)
        stack.callback(dev.close)
        return dev

    with stack:
        board = build_board(config.board, i2c=bus, spi=spi, sleep=clock.sleep,
                            overrides=config.chips.get(config.board))
        link = _link(config, clock)
        stack.enter_context(link)
        return Rig(config, clock, link, board, _stack=stack.pop_all())


def _link(config: RigConfig, clock: Clock, url: str | None = None) -> TurntableLink:
    rate = config.schedule.rate_hz
    return TurntableLink(url or config.turntable.url, profile=config.turntable.profile, clock=clock,
                         poll_interval=config.turntable.poll_every / rate)


def build_sim(config: RigConfig, *, seed: int = 0, trial: int = 0, time_scale: float | None = None,
              effects=()) -> Rig:
    """The simulated rig: everything the real one has, emulated, with the truth known.

    `effects` (from `fixtures.world.effects`) are hidden in the world, e.g. to test the discrepancy analysis.
    """
    from fixtures.simrig import SimulatedHardware

    clock = SimClock(time_scale=time_scale)
    with contextlib.ExitStack() as stack:
        hw = SimulatedHardware(config, clock, seed=seed, trial=trial, effects=effects)
        stack.enter_context(hw)
        board = build_board(config.board, i2c=hw.i2c, spi=hw.spi, set_reset=hw.set_reset, sleep=clock.sleep)
        link = _link(config, clock, hw.url)
        stack.enter_context(link)
        return Rig(config, clock, link, board, world=hw.world, fake_table=hw.turntable, truth_fn=hw.truth,
                   _stack=stack.pop_all())


def truth_after_start(rig: Rig) -> dict | None:
    """The simulator's truth in counts; only meaningful once the board started (ranges decide the counts)."""
    return None if rig.truth_fn is None else rig.truth_fn()
