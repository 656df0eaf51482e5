"""Client for a two-axis Modbus turntable, driven by a register-map profile (default `tt-map/1`).

The link, its status and its address bring pymodbus with them; they are imported when first asked for, so a
configuration checks its register-map profile where it is read (`rig.config`) without loading a Modbus stack.
"""

import importlib

from rig.turntable.errors import (CommunicationError, EStopActive, IdentityError, ModbusExceptionError,
                                  MoveRejected, MoveTimeout, ProfileError, ResponseLost, TableAlarm,
                                  TurntableError)
from rig.turntable.profile import TableProfile, load_profile

_WITH_MODBUS = {"TurntableLink": "client", "profile_time": "client", "AxisStatus": "status",
                "TableStatus": "status", "LinkAddress": "url", "parse_url": "url"}

__all__ = [
    "TurntableLink", "profile_time", "TableProfile", "load_profile", "AxisStatus", "TableStatus",
    "LinkAddress", "parse_url", "TurntableError", "CommunicationError", "ResponseLost", "IdentityError",
    "ModbusExceptionError", "MoveRejected", "MoveTimeout", "TableAlarm", "EStopActive", "ProfileError",
]


def __getattr__(name: str):
    if name in _WITH_MODBUS:
        return getattr(importlib.import_module(f"rig.turntable.{_WITH_MODBUS[name]}"), name)
    raise AttributeError(f"module 'rig.turntable' has no attribute {name!r}")
