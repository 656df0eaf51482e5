"""Register-level drivers for the rig's sensor chips and ADC.

Each driver takes an injected bus (smbus2.SMBus-like or spidev.SpiDev-like) and a `sleep` callable, so the
same code runs on hardware and on the simulated rig. The names below load their module when first used
(PEP 562), so code that needs only a constant (`drivers.units`) does not load every driver and bus library.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "ADXL312": "drivers.adxl312", "ADXL330": "drivers.adxl330", "ADXRS453": "drivers.adxrs453",
    "GyroTriad": "drivers.adxrs453", "HMC1053": "drivers.hmc1053", "HMC5843": "drivers.hmc5843",
    "ITG3200": "drivers.itg3200", "MCP3208": "drivers.mcp3208", "open_i2c": "drivers.buses", "open_spi": "drivers.buses",
    **{name: "drivers.errors" for name in ("DriverError", "BusError", "DeviceAbsent", "WrongIdentity", "ProtocolError",
                                           "SensorFault", "SensorSaturated", "FifoOverrun")},
}
__all__ = list(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'drivers' has no attribute {name!r}")
