"""What every part on a sensor board promises, declared rather than discovered.

A `Part` is anything placed on a board (an ADC, a sensor chip); a `Sensor` is a part that measures one triad.
Optional abilities are declared by inheriting a capability class, so the sampler and the board ask
`isinstance(part, DataReady)` of a declaration instead of probing attributes:

- `DataReady`: a flag that says an unread sample is waiting (the sampler waits on it and aligns its ticks).
- `Thermometer`: a die temperature (the board's temperature column).
- `SupplyMonitor`: the sensor supply voltage.
- `KeepsConfiguration`: registers written at start that a power-on reset would lose (the procedure checks them).

A part is built from its `Placement` (where it sits, declared as data in a board) and a `Wiring` (the open
buses of this rig, real or fake) by its class method `attach`; a chip family registers its classes in
`drivers.registry`.

A part class joins the registry by its own declaration: `@chip_driver` on the class files it under its `chip`
name in `REGISTERED`, and `drivers.registry` imports every module of this package, so a new chip's driver module
is found without being listed anywhere.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping, TypeVar


@dataclass(frozen=True)
class Placement:
    """Where one part sits on a board: `bus` is "i2c", "spi" or "adc" (analog, read through an ADC part)."""

    name: str                                   # the part's name on the board: "accel", "imu", "adc"
    chip: str                                   # key in drivers.registry.CHIPS
    bus: str
    address: int | None = None                  # I2C 7-bit address
    cs: int | tuple[int, ...] | None = None     # SPI chip select(s)
    adc: str | None = None                      # name of the ADC part an analog sensor is read through
    channels: tuple[int, ...] | None = None     # ADC channels of an analog sensor
    gpio: tuple[str, int] | None = None         # (gpiochip path, line offset) of a control line
    options: Mapping[str, Any] = field(default_factory=dict)   # chip settings passed to the driver


@dataclass
class Wiring:
    """The open buses a board's parts are attached to; real (`/dev/...`) or fake (emulated chips)."""

    i2c: Any = None                                             # smbus2.SMBus-like
    spi: Callable[[int, int, int], Any] | None = None           # opener (chip select, mode, max Hz) -> SpiDev
    gpio: Callable[[str, int], Callable[[int], None]] | None = None   # (chip, line) -> set/reset pulse
    sleep: Callable[[float], None] = time.sleep
    parts: dict[str, "Part"] = field(default_factory=dict)     # parts already built on this board

    def bus_for(self, placement: Placement, spi_mode: int, spi_max_hz: int) -> Any:
        """The I2C bus, or the SPI device on the placement's chip select."""
        if placement.bus == "i2c":
            if self.i2c is None:
                raise ValueError(f"{placement.name} ({placement.chip}) sits on I2C but this rig has no I2C bus")
            return self.i2c
        if placement.bus == "spi":
            if self.spi is None or placement.cs is None:
                raise ValueError(f"{placement.name} ({placement.chip}) sits on SPI without a chip select")
            return self.spi(int(placement.cs), spi_mode, spi_max_hz)
        raise ValueError(f"{placement.name} ({placement.chip}) cannot sit on bus {placement.bus!r}")

    def adc_for(self, placement: Placement) -> "Part":
        adc = self.parts.get(placement.adc or "")
        if adc is None:
            raise ValueError(f"{placement.name} ({placement.chip}) is read through ADC part {placement.adc!r}, "
                             f"which is not placed before it on this board")
        return adc


class Part(ABC):
    """A part on a board: started once, described in the session metadata."""

    chip: ClassVar[str]
    BUSES: ClassVar[tuple[str, ...]] = ()           # buses the part can sit on
    SENSES: ClassVar[tuple[str, ...]] = ()          # triads it measures: "accel", "gyro", "mag"
    OPTIONS: ClassVar[tuple[str, ...]] = ()         # chip settings a board or [chips.<part>] may give

    @abstractmethod
    def start(self) -> None:
        """Check identity, configure, wait until the first valid sample exists."""

    @abstractmethod
    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` converts counts to the physical unit."""

    @classmethod
    @abstractmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "Part":
        """Build the part where `placement` says, on `wiring`'s buses."""

    def sensor(self, kind: str) -> "Sensor":
        """The triad `kind` this part measures (a multi-sensor chip returns one of its views)."""
        if kind in self.SENSES and isinstance(self, Sensor):
            return self
        raise ValueError(f"{self.chip} does not measure {kind!r}; it measures {list(self.SENSES) or 'nothing'}")


class Sensor(Part):
    """A part that measures one triad."""

    @abstractmethod
    def read_raw(self) -> tuple[int, int, int]:
        """One sample: signed counts per axis, in the chip's axes."""


class DataReady(ABC):
    @abstractmethod
    def data_ready(self) -> bool:
        """True while an unread sample is waiting."""


class ReadsWhenReady(DataReady):
    """A chip whose data-ready flag sits just before its data registers: flag and sample in one burst."""

    @abstractmethod
    def read_if_ready(self) -> tuple[int, int, int] | None:
        """The waiting sample (as `read_raw`), or None when none is: one bus transfer for what `data_ready()`
        then `read_raw()` read in two, with the same effect on the chip."""


class KeepsConfiguration(ABC):
    @abstractmethod
    def configuration_lost(self) -> str | None:
        """What of the configuration written at start the chip no longer holds (it reset to its power-on
        registers: a brown-out, ESD), or None. A register read or two: cheap enough once per hold."""


class Thermometer(ABC):
    @abstractmethod
    def read_temperature(self) -> float:
        """Die temperature in degC."""


class SupplyMonitor(ABC):
    @abstractmethod
    def read_supply_v(self) -> float:
        """Sensor supply in volts."""


REGISTERED: dict[str, type[Part]] = {}          # chip name -> part class; read through drivers.registry.CHIPS

P = TypeVar("P", bound=type[Part])


def chip_driver(cls: P) -> P:
    """Class decorator: register a `Part` class under its `chip` name (the key boards and emulators use).

    Two different classes claiming one chip name is a mistake named here; the same class seen again (its module
    reloaded) replaces its entry."""
    if not (isinstance(cls, type) and issubclass(cls, Part)):
        raise TypeError(f"@chip_driver registers Part classes; {cls!r} is not one")
    name = cls.__dict__.get("chip")
    if not isinstance(name, str) or not name:
        raise TypeError(f"@chip_driver: {cls.__module__}.{cls.__qualname__} declares no `chip` name of its own")
    return register_once(REGISTERED, name, cls, "chip")


def register_once(table: dict, key: str, entry, what: str):
    """`table[key] = entry`, refusing a second, different entry for one key (named in the message); the same
    entry seen again (its module reloaded) replaces its old self. The drivers' and the emulators' registries."""
    known = table.get(key)
    if known is not None and (known.__module__, known.__qualname__) != (entry.__module__, entry.__qualname__):
        raise ValueError(f"{what} {key!r} registered twice: {known.__module__}.{known.__qualname__} and "
                         f"{entry.__module__}.{entry.__qualname__}")
    table[key] = entry
    return entry
