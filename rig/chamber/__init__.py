"""Client for a thermal chamber's temperature controller over Modbus, driven by a register profile
(default: a Watlow F4T, `profiles/watlow-f4t.toml`).

The link and its status bring pymodbus with them; they are imported when first asked for, so a configuration
checks its chamber profile where it is read (`rig.config`) without loading a Modbus stack.
"""

import importlib

from rig.chamber.errors import (ChamberAlarm, ChamberError, CommunicationError, IdentityError,
                                ModbusExceptionError, ProfileError, ResponseLost, SetPointNotReached)
from rig.chamber.profile import ChamberProfile, load_profile

_WITH_MODBUS = {"ChamberLink": "client", "ChamberStatus": "client"}

__all__ = ["ChamberLink", "ChamberStatus", "ChamberProfile", "load_profile", "ChamberError", "ChamberAlarm",
           "CommunicationError", "IdentityError", "ModbusExceptionError", "ProfileError", "ResponseLost",
           "SetPointNotReached"]


def __getattr__(name: str):
    if name in _WITH_MODBUS:
        return getattr(importlib.import_module(f"rig.chamber.{_WITH_MODBUS[name]}"), name)
    raise AttributeError(f"module 'rig.chamber' has no attribute {name!r}")
