"""HMC5843 3-axis magnetometer over I2C.

Registers, gains, rates and start-up follow Linux `hmc5843_core.c` (registers.md section 5); the -4096
overflow marker is from the datasheet p.15.
"""

from __future__ import annotations

import struct
import time
from typing import Any, Callable

from drivers._regs import I2cRegisters, choose
from drivers.contract import DataReady, KeepsConfiguration, Placement, Sensor, Wiring, chip_driver
from drivers.errors import SensorFault, SensorSaturated, WrongIdentity, wrap_os_error
from drivers.regmap import RegisterMap, Reg, ROBit, RWBits


class HMC5843Registers(RegisterMap):
    """HMC5843 register table (registers.md section 5; Linux hmc5843_core.c)."""

    chip = "HMC5843"
    CONFIG_A, CONFIG_B, MODE = Reg(0x00), Reg(0x01), Reg(0x02)
    DATA_X_MSB, DATA_X_LSB = Reg(0x03, access="r"), Reg(0x04, access="r")
    DATA_Y_MSB, DATA_Y_LSB = Reg(0x05, access="r"), Reg(0x06, access="r")
    DATA_Z_MSB, DATA_Z_LSB = Reg(0x07, access="r"), Reg(0x08, access="r")
    STATUS = Reg(0x09, access="r")
    ID_A, ID_B, ID_C = Reg(0x0A, access="r"), Reg(0x0B, access="r"), Reg(0x0C, access="r")

    data_rate = RWBits(3, CONFIG_A, 2)
    measurement = RWBits(2, CONFIG_A, 0)
    gain = RWBits(3, CONFIG_B, 5)
    mode = RWBits(2, MODE, 0)
    ren = ROBit(STATUS, 2)
    lock = ROBit(STATUS, 1)
    rdy = ROBit(STATUS, 0)


R = HMC5843Registers
IDENTITY = b"H43"
MS_NORMAL = 0
MODE_CONTINUOUS, MODE_SLEEP = 0, 3
OVERFLOW = -4096
AXES = "XYZ"

RATE_CODES = {0.5: 0, 1: 1, 2: 2, 5: 3, 10: 4, 20: 5, 50: 6}
GAIN_CODES = {1620: 0, 1300: 1, 970: 2, 780: 3, 530: 4, 460: 5, 390: 6, 280: 7}  # LSB per gauss
RANGE_GA = {1620: 0.7, 1300: 1.0, 970: 1.5, 780: 2.0, 530: 3.2, 460: 3.8, 390: 4.5, 280: 6.5}  # recommended [U]
UT_PER_GAUSS = 100.0
READY_POLLS, READY_POLL_S = 150, 0.02  # kernel: 150 polls of STATUS.RDY, 20 ms apart

_XYZ = struct.Struct(">hhh")


@chip_driver
class HMC5843(Sensor, DataReady, KeepsConfiguration):
    """HMC5843 in continuous mode. `gain` is in LSB per gauss (kernel table), `rate_hz` the DO output rate."""

    chip = "HMC5843"
    BUSES, SENSES, OPTIONS = ("i2c",), ("mag",), ("rate_hz", "gain")

    def __init__(self, bus: Any, address: int = 0x1E, *, rate_hz: float = 10, gain: int = 1300,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.regs = R(I2cRegisters(bus, address, self.chip, R.NAMES))
        self.bus, self.address, self.sleep = bus, address, sleep
        self._rate_code = choose(rate_hz, RATE_CODES, "output rate", self.chip, " Hz")
        self._gain_code = choose(gain, GAIN_CODES, "gain", self.chip, " LSB/Ga")
        self.rate_hz, self.gain = float(rate_hz), int(gain)
        self.started = False

    def start(self) -> None:
        """ID 'H43' -> CONFIG_A (rate, normal bias) -> CONFIG_B (gain) -> MODE continuous -> settle."""
        regs = self.regs
        ident = regs.read_block(R.ID_A, 3)
        if ident != IDENTITY:
            raise WrongIdentity(f"{regs.where(R.ID_A)}..0x0C: read {ident!r}, expected {IDENTITY!r}")
        regs.put(R.CONFIG_A, data_rate=self._rate_code, measurement=MS_NORMAL)
        regs.put(R.CONFIG_B, gain=self._gain_code)
        regs.put(R.MODE, mode=MODE_CONTINUOUS)
        self._settle()
        self.started = True

    def configuration_lost(self) -> str | None:
        """The first configuration register that no longer reads what start() wrote (a power-on reset), or None."""
        return self.regs.lost()

    def _settle(self) -> None:
        """Wait on time, not on RDY, until a sample converted with the new settings is in the registers.

        RDY is not cleared by reading (datasheet p.15: it "cannot be cleared until new data is placed in
        all the output registers"), so on a chip that measured before it says nothing about new settings.
        The first sample comes 2/rate after configuring and may still use the old gain (HMC5883L p.13,
        assumed here): wait for it, drop it, and wait one more period.
        """
        period = 1.0 / self.rate_hz
        self.sleep(2.2 * period)
        self.wait_ready()
        self.regs.read_block(R.DATA_X_MSB, 6)
        self.sleep(1.1 * period)

    def wait_ready(self) -> None:
        """Poll STATUS.RDY like the kernel (bounded); SensorFault if no conversion completes."""
        for _ in range(READY_POLLS):
            if self.regs.rdy:
                return
            self.sleep(READY_POLL_S)
        raise SensorFault(f"{self.regs.where(R.STATUS)}: RDY not set after {READY_POLLS} polls "
                          f"{READY_POLL_S * 1e3:g} ms apart")

    def set_gain(self, gain: int) -> None:
        """Change CONFIG_B gain (LSB per gauss) and wait until samples use it."""
        code = choose(gain, GAIN_CODES, "gain", self.chip, " LSB/Ga")
        self._gain_code, self.gain = code, int(gain)
        if self.started:
            self.regs.put(R.CONFIG_B, gain=code)
            self._settle()

    def set_rate(self, rate_hz: float) -> None:
        """Change the CONFIG_A data output rate and wait until samples come at it."""
        code = choose(rate_hz, RATE_CODES, "output rate", self.chip, " Hz")
        self._rate_code, self.rate_hz = code, float(rate_hz)
        if self.started:
            self.regs.put(R.CONFIG_A, data_rate=code, measurement=MS_NORMAL)
            self._settle()

    def sleep_mode(self) -> None:
        """MODE = sleep (kernel suspend); `start()` wakes it again."""
        self.regs.put(R.MODE, mode=MODE_SLEEP)
        self.started = False

    def read_raw(self) -> tuple[int, int, int]:
        """One 6-byte burst from 0x03: big-endian X, Y, Z (HMC5843 order). -4096 raises SensorSaturated."""
        try:
            xyz = _XYZ.unpack(bytes(self.bus.read_i2c_block_data(self.address, 0x03, 6)))  # DATA_X_MSB
        except OSError as exc:
            raise wrap_os_error(exc, self.regs.where(R.DATA_X_MSB), "6-byte burst read") from exc
        if OVERFLOW in xyz:
            axis = AXES[xyz.index(OVERFLOW)]
            reg = R.DATA_X_MSB.address + 2 * xyz.index(OVERFLOW)
            raise SensorSaturated(f"{self.regs.where(reg)}: {axis} axis reads -4096 (ADC overflow or "
                                  f"bias overflow) at gain {self.gain} LSB/Ga; lower the gain")
        return xyz

    def data_ready(self) -> bool:
        """STATUS.RDY: a sample exists (it stays set once the chip has measured; reading does not clear it)."""
        return bool(self.regs.rdy)

    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` is uT per count."""
        return {
            "chip": self.chip, "interface": "i2c", "address": self.address,
            "range": RANGE_GA[self.gain], "range_unit": "Ga",
            "rate_hz": self.rate_hz, "gain_lsb_per_ga": self.gain,
            "scale": UT_PER_GAUSS / self.gain, "scale_unit": "uT per LSB",
        }

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "HMC5843":
        address = 0x1E if placement.address is None else placement.address
        return cls(wiring.bus_for(placement, 0, 0), address, sleep=wiring.sleep, **placement.options)
