"""HMC5843 3-axis magnetometer over I2C.

Registers, gains, rates and start-up follow Linux `hmc5843_core.c` (registers.md section 5); the -4096
overflow marker is from the datasheet p.15.
"""

from __future__ import annotations

import struct
import time
from typing import Any, Callable

from drivers._regs import I2cRegisters, choose
from drivers.errors import SensorFault, SensorSaturated, WrongIdentity, wrap_os_error

CONFIG_A, CONFIG_B, MODE, DATA_X_MSB, STATUS, ID_A = 0x00, 0x01, 0x02, 0x03, 0x09, 0x0A
NAMES = {
    CONFIG_A: "CONFIG_A", CONFIG_B: "CONFIG_B", MODE: "MODE", DATA_X_MSB: "DATA_X_MSB", 0x04: "DATA_X_LSB",
    0x05: "DATA_Y_MSB", 0x06: "DATA_Y_LSB", 0x07: "DATA_Z_MSB", 0x08: "DATA_Z_LSB", STATUS: "STATUS",
    ID_A: "ID_A", 0x0B: "ID_B", 0x0C: "ID_C",
}

IDENTITY = b"H43"
MS_NORMAL = 0x00
MODE_CONTINUOUS, MODE_SLEEP = 0x00, 0x03
STATUS_RDY = 0x01
OVERFLOW = -4096
AXES = "XYZ"

RATE_CODES = {0.5: 0, 1: 1, 2: 2, 5: 3, 10: 4, 20: 5, 50: 6}
GAIN_CODES = {1620: 0, 1300: 1, 970: 2, 780: 3, 530: 4, 460: 5, 390: 6, 280: 7}  # LSB per gauss
RANGE_GA = {1620: 0.7, 1300: 1.0, 970: 1.5, 780: 2.0, 530: 3.2, 460: 3.8, 390: 4.5, 280: 6.5}  # recommended [U]
UT_PER_GAUSS = 100.0
READY_POLLS, READY_POLL_S = 150, 0.02  # kernel: 150 polls of STATUS.RDY, 20 ms apart

_XYZ = struct.Struct(">hhh")


class HMC5843:
    """HMC5843 in continuous mode. `gain` is in LSB per gauss (kernel table), `rate_hz` the DO output rate."""

    chip = "HMC5843"

    def __init__(self, bus: Any, address: int = 0x1E, *, rate_hz: float = 10, gain: int = 1300,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.regs = I2cRegisters(bus, address, self.chip, NAMES)
        self.bus, self.address, self.sleep = bus, address, sleep
        self._rate_code = choose(rate_hz, RATE_CODES, "output rate", self.chip, " Hz")
        self._gain_code = choose(gain, GAIN_CODES, "gain", self.chip, " LSB/Ga")
        self.rate_hz, self.gain = float(rate_hz), int(gain)
        self.started = False

    def start(self) -> None:
        """ID 'H43' -> CONFIG_A (rate, normal bias) -> CONFIG_B (gain) -> MODE continuous -> settle."""
        ident = self.regs.read_block(ID_A, 3)
        if ident != IDENTITY:
            raise WrongIdentity(f"{self.regs.where(ID_A)}..0x0C: read {ident!r}, expected {IDENTITY!r}")
        self.regs.write(CONFIG_A, (self._rate_code << 2) | MS_NORMAL)
        self.regs.write(CONFIG_B, self._gain_code << 5)
        self.regs.write(MODE, MODE_CONTINUOUS)
        self._settle()
        self.started = True

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
        self.regs.read_block(DATA_X_MSB, 6)
        self.sleep(1.1 * period)

    def wait_ready(self) -> None:
        """Poll STATUS.RDY like the kernel (bounded); SensorFault if no conversion completes."""
        for _ in range(READY_POLLS):
            if self.regs.read(STATUS) & STATUS_RDY:
                return
            self.sleep(READY_POLL_S)
        raise SensorFault(f"{self.regs.where(STATUS)}: RDY not set after {READY_POLLS} polls "
                          f"{READY_POLL_S * 1e3:g} ms apart")

    def set_gain(self, gain: int) -> None:
        """Change CONFIG_B gain (LSB per gauss) and wait until samples use it."""
        code = choose(gain, GAIN_CODES, "gain", self.chip, " LSB/Ga")
        self._gain_code, self.gain = code, int(gain)
        if self.started:
            self.regs.write(CONFIG_B, code << 5)
            self._settle()

    def set_rate(self, rate_hz: float) -> None:
        """Change the CONFIG_A data output rate and wait until samples come at it."""
        code = choose(rate_hz, RATE_CODES, "output rate", self.chip, " Hz")
        self._rate_code, self.rate_hz = code, float(rate_hz)
        if self.started:
            self.regs.write(CONFIG_A, (code << 2) | MS_NORMAL)
            self._settle()

    def sleep_mode(self) -> None:
        """MODE = sleep (kernel suspend); `start()` wakes it again."""
        self.regs.write(MODE, MODE_SLEEP)
        self.started = False

    def read_raw(self) -> tuple[int, int, int]:
        """One 6-byte burst from 0x03: big-endian X, Y, Z (HMC5843 order). -4096 raises SensorSaturated."""
        try:
            xyz = _XYZ.unpack(bytes(self.bus.read_i2c_block_data(self.address, DATA_X_MSB, 6)))
        except OSError as exc:
            raise wrap_os_error(exc, self.regs.where(DATA_X_MSB), "6-byte burst read") from exc
        if OVERFLOW in xyz:
            axis = AXES[xyz.index(OVERFLOW)]
            reg = DATA_X_MSB + 2 * xyz.index(OVERFLOW)
            raise SensorSaturated(f"{self.regs.where(reg)}: {axis} axis reads -4096 (ADC overflow or "
                                  f"bias overflow) at gain {self.gain} LSB/Ga; lower the gain")
        return xyz

    def data_ready(self) -> bool:
        """STATUS.RDY: a sample exists (it stays set once the chip has measured; reading does not clear it)."""
        return bool(self.regs.read(STATUS) & STATUS_RDY)

    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` is uT per count."""
        return {
            "chip": self.chip, "interface": "i2c", "address": self.address,
            "range": RANGE_GA[self.gain], "range_unit": "Ga",
            "rate_hz": self.rate_hz, "gain_lsb_per_ga": self.gain,
            "scale": UT_PER_GAUSS / self.gain, "scale_unit": "uT per LSB",
        }
