"""Driver error hierarchy.

Every message names the chip, where it sits (I2C address in hex or SPI chip select) and the register
(hex + name) or SPI frame (hex), so a failure in a long acquisition run can be traced to one wire.
"""

from __future__ import annotations

import errno

ABSENT_ERRNOS = frozenset({errno.EREMOTEIO, errno.ENXIO, errno.ENODEV, errno.ENOENT})


class DriverError(Exception):
    """Root of all driver errors."""


class BusError(DriverError):
    """The bus transfer itself failed (OSError from smbus2/spidev) for a reason other than absence."""


class DeviceAbsent(BusError):
    """Nobody answered: an I2C NACK (Linux: OSError errno 121 EREMOTEIO) or an SPI line stuck at a rail."""


class WrongIdentity(DriverError):
    """A device answered but its identity register holds the wrong value."""


class ProtocolError(DriverError):
    """A frame is malformed: parity error, wrong response type, null bit set, error response."""


class SensorFault(DriverError):
    """The chip reports a fault or failed a start-up self-check."""


class SensorSaturated(DriverError):
    """An output register holds the chip's overflow marker instead of a measurement."""


class FifoOverrun(DriverError):
    """The FIFO overflowed and samples were lost. `samples` holds what was drained before raising."""

    def __init__(self, message: str, samples: list) -> None:
        super().__init__(message)
        self.samples = samples


def wrap_os_error(exc: OSError, where: str, action: str) -> BusError:
    """Turn a bus OSError into DeviceAbsent (NACK-like errnos) or BusError; the caller raises `from exc`."""
    cls = DeviceAbsent if exc.errno in ABSENT_ERRNOS else BusError
    return cls(f"{where}: {action} failed: {exc}")
