"""Failures of a Modbus link, whatever device is behind it.

A device's client raises these as its own subclasses (`rig.turntable.errors`, `rig.chamber.errors`), so a
caller catching `TurntableError` or `ChamberError` sees its device's link failures too, and one catching
`LinkError` sees every device's.
"""

from __future__ import annotations

from dataclasses import dataclass

from rig.errors import RigError

# Modbus Application Protocol V1.1b3, section 7 (exception codes)
MODBUS_EXCEPTION_NAMES = {
    0x01: "ILLEGAL_FUNCTION",
    0x02: "ILLEGAL_DATA_ADDRESS",
    0x03: "ILLEGAL_DATA_VALUE",
    0x04: "SERVER_DEVICE_FAILURE",
    0x05: "ACKNOWLEDGE",
    0x06: "SERVER_DEVICE_BUSY",
    0x08: "MEMORY_PARITY_ERROR",
    0x0A: "GATEWAY_PATH_UNAVAILABLE",
    0x0B: "GATEWAY_TARGET_DEVICE_FAILED_TO_RESPOND",
}


def exception_label(code: int) -> str:
    """'ILLEGAL_DATA_ADDRESS (02)'."""
    return f"{MODBUS_EXCEPTION_NAMES.get(code, 'UNKNOWN_EXCEPTION')} ({code:02X})"


class LinkError(RigError):
    """Base of every Modbus link failure."""


class CommunicationError(LinkError):
    """No usable answer from the device after all retries (timeout, garbled frame, link down)."""


class ResponseLost(CommunicationError):
    """A non-idempotent write got no answer; whether the device acted on it is unknown."""


class ModbusExceptionError(LinkError):
    """The device answered with a Modbus exception response."""

    def __init__(self, code: int, function: int, register: str, address: int, context: str = "") -> None:
        self.code, self.function, self.register, self.address = code, function, register, address
        self.name = MODBUS_EXCEPTION_NAMES.get(code, "UNKNOWN_EXCEPTION")
        where = f"FC{function:02d} {register} @0x{address:04X}"
        super().__init__(f"{where}: {exception_label(code)}" + (f"; {context}" if context else ""))


@dataclass(frozen=True)
class LinkErrors:
    """The classes a channel raises for one kind of device (each a subclass of the generic one above)."""

    communication: type[CommunicationError] = CommunicationError
    response_lost: type[ResponseLost] = ResponseLost
    modbus_exception: type[ModbusExceptionError] = ModbusExceptionError
