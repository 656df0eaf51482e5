"""Failures of the chamber link, rooted at `ChamberError`.

The link's own failures are the shared Modbus ones (`rig.modbus.errors`) as chamber subclasses, so
`except ChamberError` sees everything the chamber raises.
"""

from __future__ import annotations

from rig.errors import RigError
from rig.modbus import errors as link


class ChamberError(RigError):
    """Base of everything the chamber link raises."""


class ProfileError(ChamberError, ValueError):
    """A chamber register profile is malformed; names the file and the key."""

    def __init__(self, file: str, key: str, message: str) -> None:
        self.file, self.key = str(file), key
        super().__init__(f"chamber profile {self.file}: key '{key}': {message}")


class CommunicationError(ChamberError, link.CommunicationError):
    """No usable answer from the chamber's controller after all retries: it stopped answering."""


class ResponseLost(CommunicationError, link.ResponseLost):
    """A non-idempotent write got no answer; whether the controller acted on it is unknown."""


class ModbusExceptionError(ChamberError, link.ModbusExceptionError):
    """The controller answered with a Modbus exception response."""


LINK_ERRORS = link.LinkErrors(CommunicationError, ResponseLost, ModbusExceptionError)


class IdentityError(ChamberError):
    """The device at the URL does not answer as the profile's controller (or reports itself failed)."""


class SetPointNotReached(ChamberError):
    """The air did not come within tolerance of the target in time. The chamber was left as it was."""

    def __init__(self, target_c: float, tolerance_c: float, air_c: float, timeout_s: float, url: str) -> None:
        self.target_c, self.tolerance_c, self.air_c, self.timeout_s = target_c, tolerance_c, air_c, timeout_s
        super().__init__(f"{url}: air did not reach {target_c:.2f} C (+-{tolerance_c:g} C) within {timeout_s:g} s: "
                         f"at {air_c:.2f} C (heating or cooling too weak, a door open, or a timeout too short "
                         "for the ramp)")


class ChamberAlarm(ChamberError):
    """The controller reports an alarm or a failed device status."""
