"""Failures of the turntable link, rooted at `TurntableError`.

Every error says which axis, register and device state it is about, because the operator has to decide
from the message alone whether to power-cycle, re-home or fix a profile.
"""

from __future__ import annotations

from rig.errors import RigError
from rig.modbus import errors as link


class TurntableError(RigError):
    """Base of everything the turntable link raises."""


class ProfileError(TurntableError, ValueError):
    """A register-map profile is malformed; names the file and the key."""

    def __init__(self, file: str, key: str, message: str) -> None:
        self.file, self.key = str(file), key
        super().__init__(f"turntable profile {self.file}: key '{key}': {message}")


class CommunicationError(TurntableError, link.CommunicationError):
    """No usable answer from the table after all retries (timeout, garbled frame, link down)."""


class ResponseLost(CommunicationError, link.ResponseLost):
    """A non-idempotent write got no answer; whether the device acted on it is unknown."""


class IdentityError(TurntableError):
    """The device at the URL is not a turntable speaking the profile's map."""


class ModbusExceptionError(TurntableError, link.ModbusExceptionError):
    """The table answered with a Modbus exception response."""


LINK_ERRORS = link.LinkErrors(CommunicationError, ResponseLost, ModbusExceptionError)


class MoveRejected(TurntableError):
    """The table refused a command or its parameters; `reason` is the axis's LAST_ERROR name."""

    def __init__(self, axis: int, axis_name: str, command: str, reason: str, cause: ModbusExceptionError) -> None:
        self.axis, self.axis_name, self.command, self.reason, self.cause = axis, axis_name, command, reason, cause
        self.code = cause.code
        super().__init__(f"axis {axis} ({axis_name}) rejected {command}: {cause}; LAST_ERROR={reason}")


class MoveTimeout(TurntableError):
    """An axis did not reach its goal in time. The table was stopped before this was raised."""

    def __init__(self, axis: int, axis_name: str, goal: str, position_deg: float, flags: frozenset[str],
                 alarm: str, timeout_s: float) -> None:
        self.axis, self.axis_name, self.position_deg = axis, axis_name, position_deg
        self.flags, self.alarm, self.timeout_s = flags, alarm, timeout_s
        super().__init__(
            f"axis {axis} ({axis_name}) did not reach {goal} within {timeout_s:.3g} s: at {position_deg:.4f} deg, "
            f"STATUS={{{', '.join(sorted(flags))}}}, ALARM_CODE={alarm}; table stopped")


class TableAlarm(TurntableError):
    """An axis or the controller reports an alarm (ALARM_CODE by name)."""

    def __init__(self, message: str, axis: int | None = None, alarm: str = "") -> None:
        self.axis, self.alarm = axis, alarm
        super().__init__(message)


class EStopActive(TurntableError):
    """The e-stop is latched: nothing moves until `reset()`."""
