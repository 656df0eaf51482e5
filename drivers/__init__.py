"""Register-level drivers for the rig's sensor chips and ADC.

Each driver takes an injected bus (smbus2.SMBus-like or spidev.SpiDev-like) and a `sleep` callable, so the
same code runs on hardware and on the simulated rig.
"""

from drivers.adxl312 import ADXL312
from drivers.adxl330 import ADXL330
from drivers.adxrs453 import ADXRS453, GyroTriad
from drivers.buses import open_i2c, open_spi
from drivers.errors import (BusError, DeviceAbsent, DriverError, FifoOverrun, ProtocolError, SensorFault,
                            SensorSaturated, WrongIdentity)
from drivers.hmc1053 import HMC1053
from drivers.hmc5843 import HMC5843
from drivers.itg3200 import ITG3200
from drivers.mcp3208 import MCP3208

__all__ = [
    "ADXL312", "ADXL330", "ADXRS453", "GyroTriad", "HMC1053", "HMC5843", "ITG3200", "MCP3208",
    "open_i2c", "open_spi",
    "DriverError", "BusError", "DeviceAbsent", "WrongIdentity", "ProtocolError", "SensorFault",
    "SensorSaturated", "FifoOverrun",
]
