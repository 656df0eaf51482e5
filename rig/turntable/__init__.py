"""Client for a two-axis Modbus turntable, driven by a register-map profile (default `tt-map/1`)."""

from rig.turntable.client import TurntableLink, profile_time
from rig.turntable.errors import (CommunicationError, EStopActive, IdentityError, ModbusExceptionError,
                                  MoveRejected, MoveTimeout, ProfileError, ResponseLost, TableAlarm,
                                  TurntableError)
from rig.turntable.profile import TableProfile, load_profile
from rig.turntable.status import AxisStatus, TableStatus
from rig.turntable.url import LinkAddress, parse_url

__all__ = [
    "TurntableLink", "profile_time", "TableProfile", "load_profile", "AxisStatus", "TableStatus",
    "LinkAddress", "parse_url", "TurntableError", "CommunicationError", "ResponseLost", "IdentityError",
    "ModbusExceptionError", "MoveRejected", "MoveTimeout", "TableAlarm", "EStopActive", "ProfileError",
]
