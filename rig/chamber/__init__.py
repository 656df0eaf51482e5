"""Client for a thermal chamber's temperature controller over Modbus, driven by a register profile
(default: a Watlow F4T, `profiles/watlow-f4t.toml`)."""

from rig.chamber.client import ChamberLink, ChamberStatus
from rig.chamber.errors import (ChamberAlarm, ChamberError, CommunicationError, IdentityError,
                                ModbusExceptionError, ProfileError, ResponseLost, SetPointNotReached)
from rig.chamber.profile import ChamberProfile, load_profile

__all__ = ["ChamberLink", "ChamberStatus", "ChamberProfile", "load_profile", "ChamberError", "ChamberAlarm",
           "CommunicationError", "IdentityError", "ModbusExceptionError", "ProfileError", "ResponseLost",
           "SetPointNotReached"]
