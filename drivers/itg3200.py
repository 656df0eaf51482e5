"""ITG-3200 3-axis digital gyroscope over I2C.

Register map, ID check, reset and scale follow Linux `itg3200_core.c` / `itg3200.h` (registers.md section 3),
except that register addresses are sent plain: the kernel sets bit 7, which the chip ignores, but a
datasheet-faithful device need not.
"""

from __future__ import annotations

import math
import struct
import time
from typing import Any, Callable

from drivers._regs import I2cRegisters, choose
from drivers.contract import (KeepsConfiguration, Placement, ReadsWhenReady, Sensor, Thermometer, Wiring,
                              chip_driver)
from drivers.errors import SensorFault, WrongIdentity, wrap_os_error
from drivers.regmap import RegisterMap, Reg, ROBit, RWBit, RWBits


class ITG3200Registers(RegisterMap):
    """ITG-3200 register table (registers.md section 3; Linux itg3200.h)."""

    chip = "ITG-3200"
    WHO_AM_I, SMPLRT_DIV, DLPF_FS, INT_CFG = Reg(0x00), Reg(0x15), Reg(0x16), Reg(0x17)
    INT_STATUS = Reg(0x1A, access="r")
    TEMP_OUT_H, TEMP_OUT_L = Reg(0x1B, access="r"), Reg(0x1C, access="r")
    GYRO_XOUT_H, GYRO_XOUT_L = Reg(0x1D, access="r"), Reg(0x1E, access="r")
    GYRO_YOUT_H, GYRO_YOUT_L = Reg(0x1F, access="r"), Reg(0x20, access="r")
    GYRO_ZOUT_H, GYRO_ZOUT_L = Reg(0x21, access="r"), Reg(0x22, access="r")
    PWR_MGM = Reg(0x3E)

    id = RWBits(6, WHO_AM_I, 1)
    fs_sel = RWBits(2, DLPF_FS, 3)
    dlpf_cfg = RWBits(3, DLPF_FS, 0)
    actl = RWBit(INT_CFG, 7)
    open_drain = RWBit(INT_CFG, 6)
    latch_int_en = RWBit(INT_CFG, 5)
    int_anyrd_2clear = RWBit(INT_CFG, 4)
    itg_rdy_en = RWBit(INT_CFG, 2)
    raw_rdy_en = RWBit(INT_CFG, 0)
    itg_rdy = ROBit(INT_STATUS, 2)
    raw_data_rdy = ROBit(INT_STATUS, 0)
    h_reset = RWBit(PWR_MGM, 7)
    sleep = RWBit(PWR_MGM, 6)
    stby = RWBits(3, PWR_MGM, 3)
    clk_sel = RWBits(3, PWR_MGM, 0)


R = ITG3200Registers
ID_BITS = 0x34                      # WHO_AM_I bits 6:1
CLK_PLL_X = 1
FS_SEL_2000 = 3                     # the only documented full scale
INT_CFG_FIELDS = {"latch_int_en": 1, "int_anyrd_2clear": 1, "itg_rdy_en": 1, "raw_rdy_en": 1}

DLPF_CODES = {256: 0, 188: 1, 98: 2, 42: 3, 20: 4, 10: 5, 5: 6}
LSB_PER_DPS = 14.375
RANGE_DPS = 2000.0
RESET_WAIT_S = 1.5e-3               # kernel: 1 ms PLL settling + margin
READY_POLLS, READY_POLL_S = 20, 5e-3  # up to 100 ms for ITG_RDY (start-up ~50 ms [U])

_XYZ = struct.Struct(">hhh")
_T = struct.Struct(">h")
_STATUS_TO_Z = 9                    # INT_STATUS 0x1A .. GYRO_ZOUT_L 0x22, one auto-increment burst
_STATUS_TO_TEMP = 3                 # INT_STATUS 0x1A, TEMP_OUT_H, TEMP_OUT_L


def internal_rate_hz(dlpf_hz: int) -> int:
    """8 kHz internal sampling with DLPF_CFG = 0 (256 Hz), else 1 kHz (datasheet 8.2, kernel)."""
    return 8000 if DLPF_CODES[dlpf_hz] == 0 else 1000


def exact_rates(dlpf_hz: int) -> dict[float, int]:
    """Output rates reachable exactly as internal/(SMPLRT_DIV+1), SMPLRT_DIV 0..255, mapped to the divider."""
    internal = internal_rate_hz(dlpf_hz)
    return {internal // (d + 1): d for d in range(256) if internal % (d + 1) == 0}


@chip_driver
class ITG3200(Sensor, ReadsWhenReady, Thermometer, KeepsConfiguration):
    """ITG-3200 at +-2000 deg/s with the PLL on the X gyro as clock.

    INT_CFG latches the interrupt and lets any read clear it: a polled or level-triggered host never misses the
    50 us pulse the default mode gives, and reading the sample acknowledges it, so `data_ready()` means "an
    unread sample is waiting". A temperature read would clear that flag too, hiding a sample not yet read: it
    reads INT_STATUS with the temperature and keeps the flag it cleared for the next poll.
    """

    chip = "ITG-3200"
    BUSES, SENSES, OPTIONS = ("i2c",), ("gyro",), ("rate_hz", "dlpf_hz")

    def __init__(self, bus: Any, address: int = 0x68, *, rate_hz: float = 100, dlpf_hz: int = 42,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.regs = R(I2cRegisters(bus, address, self.chip, R.NAMES))
        self.bus, self.address, self.sleep = bus, address, sleep
        self._dlpf_code = choose(dlpf_hz, DLPF_CODES, "low-pass bandwidth", self.chip, " Hz")
        self._divider = choose(rate_hz, exact_rates(dlpf_hz), f"sample rate with DLPF {dlpf_hz} Hz",
                               self.chip, " Hz")
        self.rate_hz, self.dlpf_hz = float(rate_hz), int(dlpf_hz)
        self.started = False
        self._unread = False            # RAW_DATA_RDY a temperature read cleared before the sample was read

    def start(self) -> None:
        """ID -> H_RESET -> INT_CFG -> CLK_SEL PLL X -> DLPF_FS -> SMPLRT_DIV -> wait ITG_RDY -> verify DLPF_FS.

        INT_CFG (with ITG_RDY_EN) is written before the clock switch so the PLL-ready flag cannot be missed.
        """
        regs = self.regs
        who = regs.read(R.WHO_AM_I)
        if R.id.get(who) != ID_BITS:
            raise WrongIdentity(f"{regs.where(R.WHO_AM_I)}: read 0x{who:02X}, bits 6:1 should be "
                                f"0x{ID_BITS:02X}")
        regs.put(R.PWR_MGM, h_reset=1)
        self.sleep(RESET_WAIT_S)
        regs.put(R.INT_CFG, **INT_CFG_FIELDS)
        regs.put(R.PWR_MGM, clk_sel=CLK_PLL_X)
        wrote = R.compose(R.DLPF_FS, fs_sel=FS_SEL_2000, dlpf_cfg=self._dlpf_code)
        regs.write(R.DLPF_FS, wrote)
        regs.write(R.SMPLRT_DIV, self._divider)                 # a plain 8-bit divider, no fields
        self._wait_pll_ready()
        dlpf_fs = regs.read(R.DLPF_FS)
        if dlpf_fs != wrote:
            raise SensorFault(f"{regs.where(R.DLPF_FS)}: read back 0x{dlpf_fs:02X}, wrote 0x{wrote:02X}")
        self._discard_first_sample()
        self.started = True

    def configuration_lost(self) -> str | None:
        """The first configuration register that no longer reads what start() wrote (a power-on reset), or None.

        Each of those reads clears RAW_DATA_RDY (any-read-clear): INT_STATUS is read first, and a sample it
        announces is kept as unread for the next poll (one arriving during the few reads after it stays hidden)."""
        self._unread = self._unread or bool(self.regs.raw_data_rdy)
        return self.regs.lost()

    def _discard_first_sample(self) -> None:
        """Wait for RAW_DATA_RDY and drop that sample.

        ITG_RDY only says the PLL runs; the data registers may still hold reset zeros or a sample taken
        before FS_SEL and the rate were set, for up to one sample period after configuring.
        """
        period = 1.0 / self.rate_hz
        step = min(period / 4, READY_POLL_S)
        polls = int((2 * period + 0.05) / step) + 1
        for _ in range(polls):
            if self.regs.raw_data_rdy:
                self.read_raw()
                return
            self.sleep(step)
        raise SensorFault(f"{self.regs.where(R.INT_STATUS)}: RAW_DATA_RDY not set within "
                          f"{polls * step * 1e3:.0f} ms of configuring {self.rate_hz:g} Hz")

    def _wait_pll_ready(self) -> None:
        for _ in range(READY_POLLS):
            if self.regs.itg_rdy:
                return
            self.sleep(READY_POLL_S)
        raise SensorFault(f"{self.regs.where(R.INT_STATUS)}: ITG_RDY (PLL ready) not set after "
                          f"{READY_POLLS} polls {READY_POLL_S * 1e3:g} ms apart")

    def set_rate(self, rate_hz: float) -> None:
        """Change the output rate; only rates exact for the current DLPF setting are allowed."""
        divider = choose(rate_hz, exact_rates(self.dlpf_hz), f"sample rate with DLPF {self.dlpf_hz} Hz",
                         self.chip, " Hz")
        if self.started:
            self.regs.write(R.SMPLRT_DIV, divider)
        self._divider, self.rate_hz = divider, float(rate_hz)

    def read_raw(self) -> tuple[int, int, int]:
        """One 6-byte burst from GYRO_XOUT_H: big-endian signed X, Y, Z at 14.375 LSB per deg/s."""
        try:
            raw = _XYZ.unpack(bytes(self.bus.read_i2c_block_data(self.address, 0x1D, 6)))  # GYRO_XOUT_H
        except OSError as exc:
            raise wrap_os_error(exc, self.regs.where(R.GYRO_XOUT_H), "6-byte burst read") from exc
        self._unread = False
        return raw

    def read_if_ready(self) -> tuple[int, int, int] | None:
        """INT_STATUS through GYRO_ZOUT_L in one 9-byte burst (registers auto-increment, registers.md 3.1): X, Y,
        Z if RAW_DATA_RDY was set, else None. Reading INT_STATUS clears the latched flag, as `data_ready()` does."""
        try:
            raw = bytes(self.bus.read_i2c_block_data(self.address, 0x1A, _STATUS_TO_Z))  # INT_STATUS
        except OSError as exc:
            raise wrap_os_error(exc, self.regs.where(R.INT_STATUS), f"{_STATUS_TO_Z}-byte burst read") from exc
        ready, self._unread = R.raw_data_rdy.get(raw[0]) or self._unread, False
        return _XYZ.unpack_from(raw, 3) if ready else None

    def read_temperature(self) -> float:
        """Die temperature in degC: (raw + 23000) / 280 (kernel offset and scale), read in one 3-byte burst with
        INT_STATUS before it: the read clears RAW_DATA_RDY (any-read-clear), so a sample it announced is kept as
        unread for the next `read_if_ready`/`data_ready`."""
        try:
            raw = bytes(self.bus.read_i2c_block_data(self.address, 0x1A, _STATUS_TO_TEMP))  # INT_STATUS
        except OSError as exc:
            raise wrap_os_error(exc, self.regs.where(R.INT_STATUS), f"{_STATUS_TO_TEMP}-byte burst read") from exc
        self._unread = self._unread or bool(R.raw_data_rdy.get(raw[0]))
        (temp,) = _T.unpack_from(raw, 1)
        return (temp + 23000) / 280.0

    def data_ready(self) -> bool:
        """INT_STATUS.RAW_DATA_RDY (this read also clears the latched flag), or a flag a temperature read cleared
        before its sample was read."""
        ready, self._unread = bool(self.regs.raw_data_rdy) or self._unread, False
        return ready

    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` is rad/s per count."""
        return {
            "chip": self.chip, "interface": "i2c", "address": self.address,
            "range": RANGE_DPS, "range_unit": "deg/s",
            "rate_hz": self.rate_hz, "dlpf_hz": self.dlpf_hz,
            "scale": math.radians(1.0 / LSB_PER_DPS), "scale_unit": "rad/s per LSB",
        }

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "ITG3200":
        address = 0x68 if placement.address is None else placement.address
        return cls(wiring.bus_for(placement, 0, 0), address, sleep=wiring.sleep, **placement.options)
