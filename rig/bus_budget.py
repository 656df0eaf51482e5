"""The bus time each sample tick needs, from the transfers the board's own drivers make.

The drivers are run once against counting wrappers of the buses (`CountingI2C`, `CountingSpi`, `counting_wiring`):
each sensor's per-sample read (the sampler's data-ready poll and its read, or the one burst of a chip that reads
both at once), and the temperature and supply reads. Each transfer is then timed on the wire:

- I2C (UM10204 section 3.1): every byte, the address byte included, is 9 SCL periods (8 bits and the ACK); a
  transfer is START, its messages (a repeated START between two), STOP. START, repeated START and STOP are
  charged one SCL period each: the set-up and hold times around them (t_SU;STA, t_HD;STA, t_SU;STO) and the bus
  free time after a STOP (t_BUF) are each about half a period to a period at 100 and 400 kHz (UM10204 Table 10).
  So a transfer of m messages carrying n bytes in all takes (9 (m + n) + m + 1) / f_SCL.
- SPI: 8 clocks per byte at the speed the driver opened the device with, plus SPI_FRAME_OVERHEAD_S per chip-select
  frame (CS set-up, hold and the time CS stays high between frames; the MCP3208 asks 500 ns high, the ADXRS453 and
  ADXL312 less) [U: a round figure above the chips' minimums].
- An I2C switch (`drivers.tca9548a`): one select write (address + 1 byte: 19 SCL periods + START + STOP) per change
  of channel within a tick, counting the change back to the first channel at the start of the next tick.

The host's own time per transfer (a system call, the driver's arithmetic) is not counted: this is the wire's time.

A tick reads every sensor; the magnetometer only every `mag_every` ticks and temperature/supply every `aux_every`
(as `procedures.acquisition.Sampler` does), so the budget is the mean per tick over one cycle of those and the
worst tick. A rate is carried when the worst tick's bus time fits in the tick period on every bus, and the sum over
buses fits too (the sampler reads them one after another).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Iterable, Sequence

from drivers.contract import DataReady, ReadsWhenReady, Wiring
from drivers.errors import DriverError
from rig.board import SensorBoard, build_board, i2c_clock_hz

SPI_FRAME_OVERHEAD_S = 1.0e-6
I2C_BITS_PER_BYTE = 9
I2C_CONDITION_PERIODS = 1           # START, repeated START, STOP: one SCL period each
AUX_EVERY = 10                      # temperature and supply every N ticks (procedures.acquisition.Sampler default)
WARM_UP_TICKS = 50                  # ticks read before the traffic of one must repeat (board_reads)
SELECT_BYTES = 1                    # a switch select: the address and one control byte


@dataclass(frozen=True)
class I2CTransfer:
    """START ... STOP to one address: messages as (is_read, bytes), a repeated START between two."""

    address: int
    messages: tuple[tuple[bool, int], ...]

    @property
    def bytes(self) -> int:
        return sum(n for _, n in self.messages)

    def seconds(self, clock_hz: float) -> float:
        m = len(self.messages)
        periods = I2C_BITS_PER_BYTE * (m + self.bytes) + I2C_CONDITION_PERIODS * (m + 1)
        return periods / clock_hz


@dataclass(frozen=True)
class SpiFrame:
    """One chip-select frame of `length` bytes clocked at `speed_hz`."""

    length: int
    speed_hz: int

    @property
    def bytes(self) -> int:
        return self.length

    def seconds(self, clock_hz: float) -> float:
        return 8 * self.length / self.speed_hz + SPI_FRAME_OVERHEAD_S


SELECT = I2CTransfer(0x70, ((False, SELECT_BYTES),))     # the switch's address does not change its timing


@dataclass(frozen=True)
class TickRead:
    """What one sensor (or the temperature/supply pair) costs when it is read: (bus name, transfer) in order."""

    name: str
    every: int
    transfers: tuple[tuple[str, I2CTransfer | SpiFrame], ...]


@dataclass(frozen=True)
class BusLoad:
    """One bus's share of a tick: the mean seconds per tick, and the transfers and bytes of its busiest tick.

    `worst_tick_s` is the busiest tick's seconds, `cycle_ticks` the ticks after which the pattern repeats."""

    bus: str
    seconds_per_tick: float
    transfers: int
    bytes: int
    worst_tick_s: float = 0.0
    cycle_ticks: int = 1

    def load(self, rate_hz: float) -> float:
        """The busiest tick's bus time as a fraction of the tick period."""
        return self.worst_tick_s * rate_hz

    def max_rate_hz(self) -> float:
        """The highest tick rate (to 0.1 Hz below) whose busiest tick still fits in its period."""
        return math.inf if self.worst_tick_s <= 0 else math.floor(10.0 / self.worst_tick_s) / 10.0


class TrafficLog:
    """Transfers seen by counting wrappers, in order: (bus name, transfer)."""

    def __init__(self) -> None:
        self.entries: list[tuple[str, I2CTransfer | SpiFrame]] = []

    def add(self, bus: str, transfer: I2CTransfer | SpiFrame) -> None:
        self.entries.append((bus, transfer))

    def during(self, action: Callable[[], Any]) -> tuple[tuple[str, I2CTransfer | SpiFrame], ...]:
        """The transfers `action()` makes; a driver error (a sample not ready, saturated) leaves them counted, as
        the sampler's retry would pay them too."""
        start = len(self.entries)
        try:
            action()
        except DriverError:
            pass
        return tuple(self.entries[start:])


class WireTimedLog(TrafficLog):
    """A `TrafficLog` that also stamps each transfer with the clock's time and makes the clock pay its wire time
    (with `charge`: a simulated clock then runs as slowly as the real buses would let the sampler run): a session read through
    counting wrappers of its fake buses gives the bus time each tick actually used (`ticks_of`)."""

    def __init__(self, clock: Any, i2c_clock: int, *, charge: bool = True) -> None:
        super().__init__()
        self.clock, self.i2c_clock, self.charge = clock, i2c_clock, charge
        self.times: list[float] = []

    def add(self, bus: str, transfer: I2CTransfer | SpiFrame) -> None:
        super().add(bus, transfer)
        self.times.append(self.clock.now())
        if self.charge:
            self.clock.sleep(transfer.seconds(self.i2c_clock))

    def bus_seconds(self) -> dict[str, float]:
        """Each bus's wire seconds over every transfer logged: divided by the ticks a session read, the bus time
        per tick it paid, whether or not its ticks' transfers ran back to back (`ticks_of` needs gaps)."""
        total: dict[str, float] = {}
        for bus, transfer in self.entries:
            total[bus] = total.get(bus, 0.0) + transfer.seconds(self.i2c_clock)
        return total

    def ticks_of(self, period_s: float, since: float = 0.0) -> list[dict[str, float]]:
        """Per tick after clock time `since`, each bus's wire seconds: a tick is a run of transfers with no gap of
        half a period or more between one's end and the next's start."""
        ticks: list[dict[str, float]] = []
        end = -math.inf
        for t, (bus, transfer) in zip(self.times, self.entries):
            if t < since:
                continue
            if t - end >= period_s / 2:
                ticks.append({})
            seconds = transfer.seconds(self.i2c_clock)
            ticks[-1][bus] = ticks[-1].get(bus, 0.0) + seconds
            end = t + seconds
        return ticks


def _w(n: int) -> tuple[bool, int]:
    return (False, n)


def _r(n: int) -> tuple[bool, int]:
    return (True, n)


class CountingI2C:
    """An smbus2.SMBus-like wrapper that logs each transfer's wire messages, then delegates to `bus`."""

    def __init__(self, bus: Any, log: TrafficLog, name: str = "I2C bus") -> None:
        self.bus, self.log, self.name = bus, log, name

    def _add(self, address: int, *messages: tuple[bool, int]) -> None:
        self.log.add(self.name, I2CTransfer(address, messages))

    def write_quick(self, a: int, force: Any = None) -> None:
        self._add(a, _w(0))
        return self.bus.write_quick(a, force)

    def read_byte(self, a: int, force: Any = None) -> int:
        self._add(a, _r(1))
        return self.bus.read_byte(a, force)

    def write_byte(self, a: int, value: int, force: Any = None) -> None:
        self._add(a, _w(1))
        return self.bus.write_byte(a, value, force)

    def read_byte_data(self, a: int, register: int, force: Any = None) -> int:
        self._add(a, _w(1), _r(1))
        return self.bus.read_byte_data(a, register, force)

    def write_byte_data(self, a: int, register: int, value: int, force: Any = None) -> None:
        self._add(a, _w(2))
        return self.bus.write_byte_data(a, register, value, force)

    def read_word_data(self, a: int, register: int, force: Any = None) -> int:
        self._add(a, _w(1), _r(2))
        return self.bus.read_word_data(a, register, force)

    def write_word_data(self, a: int, register: int, value: int, force: Any = None) -> None:
        self._add(a, _w(3))
        return self.bus.write_word_data(a, register, value, force)

    def process_call(self, a: int, register: int, value: int, force: Any = None) -> int:
        self._add(a, _w(3), _r(2))
        return self.bus.process_call(a, register, value, force)

    def read_block_data(self, a: int, register: int, force: Any = None) -> list[int]:
        out = self.bus.read_block_data(a, register, force)
        self._add(a, _w(1), _r(1 + len(out)))
        return out

    def write_block_data(self, a: int, register: int, data: list[int], force: Any = None) -> None:
        self._add(a, _w(2 + len(data)))
        return self.bus.write_block_data(a, register, data, force)

    def read_i2c_block_data(self, a: int, register: int, length: int, force: Any = None) -> list[int]:
        self._add(a, _w(1), _r(length))
        return self.bus.read_i2c_block_data(a, register, length, force)

    def write_i2c_block_data(self, a: int, register: int, data: list[int], force: Any = None) -> None:
        self._add(a, _w(1 + len(data)))
        return self.bus.write_i2c_block_data(a, register, data, force)

    def i2c_rdwr(self, *msgs: Any) -> None:
        """One combined transaction (one START ... STOP, a repeated START between messages): one transfer."""
        if msgs:
            self.log.add(self.name, I2CTransfer(msgs[0].addr, tuple((bool(m.flags & 1), m.len) for m in msgs)))
        return self.bus.i2c_rdwr(*msgs)

    def close(self) -> None:
        return self.bus.close()


class CountingSpi:
    """A spidev.SpiDev-like wrapper that logs each chip-select frame, then delegates to `spi`."""

    def __init__(self, spi: Any, log: TrafficLog, name: str = "SPI bus") -> None:
        object.__setattr__(self, "spi", spi)
        object.__setattr__(self, "log", log)
        object.__setattr__(self, "name", name)

    def __getattr__(self, attr: str) -> Any:
        return getattr(self.spi, attr)

    def __setattr__(self, attr: str, value: Any) -> None:
        setattr(self.spi, attr, value)

    def _frame(self, n: int, speed_hz: int = 0) -> None:
        self.log.add(self.name, SpiFrame(n, int(speed_hz or self.spi.max_speed_hz)))

    def xfer(self, data: list[int], speed_hz: int = 0, *rest: int) -> list[int]:
        for _ in data:
            self._frame(1, speed_hz)
        return self.spi.xfer(data, speed_hz, *rest)

    def xfer2(self, data: list[int], speed_hz: int = 0, *rest: int) -> list[int]:
        self._frame(len(data), speed_hz)
        return self.spi.xfer2(data, speed_hz, *rest)

    def xfer3(self, data: list[int], speed_hz: int = 0, *rest: int) -> list[int]:
        self._frame(len(data), speed_hz)
        return self.spi.xfer3(data, speed_hz, *rest)

    def readbytes(self, length: int) -> list[int]:
        self._frame(length)
        return self.spi.readbytes(length)

    def writebytes(self, values: list[int]) -> None:
        self._frame(len(values))
        return self.spi.writebytes(values)

    def writebytes2(self, values: Iterable[int]) -> None:
        values = list(values)
        self._frame(len(values))
        return self.spi.writebytes2(values)


def counting_wiring(wiring: Wiring, log: TrafficLog, i2c_name: str = "I2C bus",
                    spi_name: str = "SPI bus") -> Wiring:
    """`wiring` with its I2C bus and every SPI device it opens logging into `log` (all chip selects share one
    SPI bus: one name)."""
    opener = wiring.spi
    spi = None if opener is None else (lambda cs, mode, hz: CountingSpi(opener(cs, mode, hz), log, spi_name))
    i2c = None if wiring.i2c is None else CountingI2C(wiring.i2c, log, i2c_name)
    return replace(wiring, i2c=i2c, spi=spi, parts={})


def bus_names(chips: dict) -> tuple[str, str]:
    """The names of the board's I2C and SPI buses, as `rig.assembly` opens them."""
    return f"I2C bus {int(chips.get('i2c_bus', 1))}", f"SPI bus {int(chips.get('spi_bus', 0))}"


def board_reads(board: SensorBoard, log: TrafficLog, *, mag_every: int, aux_every: int = AUX_EVERY,
                settle: Callable[[], None] | None = None) -> list[TickRead]:
    """Each sensor's per-sample transfers and the temperature/supply reads of a started `board` whose buses log
    into `log`, the way the sampler reads them (its first poll finds the sample ready).

    The board is read tick after tick, `settle()` (one tick period passing) before each, until a tick costs what
    the one before it did (at most WARM_UP_TICKS): a chip read from its FIFO drains what came since its last read,
    the backlog of its start-up first, so only a steady tick shows the cost a session pays (one drain for both the
    accelerometer and the gyroscope of an LSM6DSO)."""
    actions = []
    for name, triad in board.triads.items():
        if isinstance(triad, ReadsWhenReady):
            action = triad.read_if_ready
        elif isinstance(triad, DataReady):
            def action(triad=triad):
                triad.data_ready()
                triad.read_raw()
        else:
            action = triad.read_raw
        actions.append((name, mag_every if name == "mag" else 1, action))

    def aux() -> None:
        board.read_temperature()
        board.read_supply()

    actions.append(("temperature/supply", aux_every, aux))
    reads: list[TickRead] = []
    for _ in range(WARM_UP_TICKS):
        if settle is not None:
            settle()
        before, reads = reads, [TickRead(name, every, log.during(action)) for name, every, action in actions]
        if reads == before:
            break
    return reads


def tick_loads(reads: Sequence[tuple[str, TickRead, int | None]], *, i2c_clock: int = 100_000) -> list[BusLoad]:
    """Per bus, the mean and worst tick of `reads`: (the bus its mux switch sits on, the read, the switch channel
    or None when it sits on the bus directly), read in this order every tick it is due.

    The reads' transfers must not include the switch's select writes: those are added here, one per change of
    channel (a switch per bus; MuxChannel writes only on a change)."""
    if not reads:
        return []
    cycle = math.lcm(*(max(1, r.every) for _, r, _ in reads))
    buses = list(dict.fromkeys([b for _, r, _ in reads for b, _ in r.transfers] +
                               [b for b, _, ch in reads if ch is not None]))
    last: dict[str, int] = {}
    ticks: list[dict[str, list]] = []
    for k in range(2 * cycle):                   # the first cycle sets where the switch starts the second
        tick: dict[str, list] = {b: [] for b in buses}
        for bus, read, channel in reads:
            if k % max(1, read.every):
                continue
            if channel is not None and last.get(bus) != channel:
                tick[bus].append(SELECT)
                last[bus] = channel
            for b, transfer in read.transfers:
                tick[b].append(transfer)
        ticks.append(tick)
    steady = ticks[cycle:]
    out = []
    for b in buses:
        times = [sum(t.seconds(i2c_clock) for t in tick[b]) for tick in steady]
        worst = max(range(cycle), key=lambda i: times[i])
        out.append(BusLoad(b, sum(times) / cycle, len(steady[worst][b]), sum(t.bytes for t in steady[worst][b]),
                           times[worst], cycle))
    return out


def tick_budget(config: Any, wiring: Wiring, *, aux_every: int = AUX_EVERY,
                settle: Callable[[], None] | None = None) -> list[BusLoad]:
    """The bus loads of the configuration's board (one board, no switch), built and started on `wiring` (fake or
    real buses; they are only read, as a session's start and first samples read them)."""
    log = TrafficLog()
    i2c_name, spi_name = bus_names(config.chips)
    board = build_board(config.board, counting_wiring(wiring, log, i2c_name, spi_name), chips=config.chips)
    board.start()
    reads = board_reads(board, log, mag_every=config.schedule.mag_every, aux_every=aux_every, settle=settle)
    return tick_loads([(i2c_name, r, None) for r in reads], i2c_clock=i2c_clock_hz(config.chips))


def refusal(loads: Sequence[BusLoad], rate_hz: float) -> str | None:
    """Why the buses cannot carry `rate_hz` (the first bus whose busiest tick overruns the period, else all buses
    together), or None."""
    for load in loads:
        if load.load(rate_hz) > 1.0:
            return (f"{load.bus} needs {load.worst_tick_s * 1e3:.3g} ms of its busiest tick, "
                    f"{load.load(rate_hz) * 100:.0f} % of the {1e3 / rate_hz:.3g} ms tick at {rate_hz:g} Hz; it "
                    f"carries at most {load.max_rate_hz():g} Hz")
    total = sum(load.worst_tick_s for load in loads)
    if total * rate_hz > 1.0:
        names = ", ".join(load.bus for load in loads)
        return (f"{names} together need {total * 1e3:.3g} ms of a tick (read one after another), "
                f"{total * rate_hz * 100:.0f} % of the {1e3 / rate_hz:.3g} ms tick at {rate_hz:g} Hz; they carry "
                f"at most {math.floor(10 / total) / 10:g} Hz")
    return None
