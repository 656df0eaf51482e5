"""ADXL312 3-axis digital accelerometer over I2C or SPI (mode 3).

Register map and start-up follow the Linux `adxl313` driver family (ADXL312 variant) and ADI no-OS
`adxl313.h`; see registers.md section 1. The ADXL312 has no soft-reset or part-ID registers beyond DEVID.
"""

from __future__ import annotations

import struct
import time
from typing import Any, Callable

from drivers._regs import I2cRegisters, SpiRegisters, check_not_floating, choose, spi_label
from drivers.errors import FifoOverrun, WrongIdentity, wrap_os_error

DEVID, OFSX, OFSY, OFSZ = 0x00, 0x1E, 0x1F, 0x20
BW_RATE, POWER_CTL, INT_ENABLE, INT_MAP, INT_SOURCE, DATA_FORMAT = 0x2C, 0x2D, 0x2E, 0x2F, 0x30, 0x31
DATAX0, FIFO_CTL, FIFO_STATUS = 0x32, 0x38, 0x39
NAMES = {
    DEVID: "DEVID", OFSX: "OFSX", OFSY: "OFSY", OFSZ: "OFSZ", BW_RATE: "BW_RATE", POWER_CTL: "POWER_CTL",
    INT_ENABLE: "INT_ENABLE", INT_MAP: "INT_MAP", INT_SOURCE: "INT_SOURCE", DATA_FORMAT: "DATA_FORMAT",
    DATAX0: "DATAX0", 0x33: "DATAX1", 0x34: "DATAY0", 0x35: "DATAY1", 0x36: "DATAZ0", 0x37: "DATAZ1",
    FIFO_CTL: "FIFO_CTL", FIFO_STATUS: "FIFO_STATUS",
}

DEVID_ADXL312 = 0xE5
MEASURE = 0x08
FULL_RES = 0x08
INT_DATA_READY, INT_WATERMARK, INT_OVERRUN = 0x80, 0x02, 0x01
FIFO_BYPASS, FIFO_STREAM = 0x00, 0x80
FIFO_ENTRIES_MASK = 0x3F
FIFO_DEPTH = 32

RANGE_CODES = {1.5: 0, 3: 1, 6: 2, 12: 3}
RATE_CODES = {6.25: 0x6, 12.5: 0x7, 25: 0x8, 50: 0x9, 100: 0xA, 200: 0xB, 400: 0xC, 800: 0xD, 1600: 0xE, 3200: 0xF}
STANDARD_GRAVITY = 9.80665
LSB_PER_G = 345.0  # full resolution, every range (kernel 9.80665/345 m/s^2 per LSB; datasheet 2.9 mg/LSB typ)

SPI_MODE = 3
SPI_MAX_HZ = 5_000_000

_XYZ = struct.Struct("<HHH")


class ADXL312:
    """ADXL312 in full-resolution mode; `bus` is an smbus2.SMBus-like object or, if it has `xfer2`, a SpiDev.

    Full resolution keeps 2.9 mg/LSB in every range, so only the number of valid bits (10..13) changes with
    the range; read paths sign-extend from that width so a chip that leaves the upper bits clear still decodes.
    """

    chip = "ADXL312"

    def __init__(self, bus: Any, address: int = 0x53, *, range_g: float = 12, rate_hz: float = 100,
                 cs: Any = None, sleep: Callable[[float], None] = time.sleep) -> None:
        self.is_spi = hasattr(bus, "xfer2")
        if self.is_spi:
            self.regs: Any = SpiRegisters(bus, spi_label(bus, cs), self.chip, NAMES)
        else:
            self.regs = I2cRegisters(bus, address, self.chip, NAMES)
        self.bus, self.address, self.sleep = bus, address, sleep
        self._range_code = choose(range_g, RANGE_CODES, "range", self.chip, " g")
        self._rate_code = choose(rate_hz, RATE_CODES, "output data rate", self.chip, " Hz")
        self.range_g, self.rate_hz = float(range_g), float(rate_hz)
        self._set_bits(self._range_code)
        self.started = False
        self.watermark: int | None = None

    def _set_bits(self, range_code: int) -> None:
        bits = 10 + range_code
        self._mask, self._sign = (1 << bits) - 1, 1 << (bits - 1)

    def start(self) -> None:
        """Identity check, then standby -> full-res range -> rate -> FIFO bypass -> MEASURE, then turn-on wait."""
        devid = self.regs.read(DEVID)
        if self.is_spi:
            check_not_floating(devid, self.regs.where(DEVID))
        if devid != DEVID_ADXL312:
            raise WrongIdentity(f"{self.regs.where(DEVID)}: read 0x{devid:02X}, expected 0x{DEVID_ADXL312:02X}")
        self.regs.write(POWER_CTL, 0x00)
        self.regs.write(DATA_FORMAT, FULL_RES | self._range_code)
        self.regs.write(BW_RATE, self._rate_code)
        self.regs.write(INT_ENABLE, 0x00)
        self.regs.write(FIFO_CTL, FIFO_BYPASS)
        self.regs.write(POWER_CTL, MEASURE)
        self.sleep(1.0 / self.rate_hz + 1.1e-3)  # turn-on time tau + 1.1 ms (datasheet p.4 note 5)
        self.started = True

    def set_range(self, range_g: float) -> None:
        """Change the range (+-1.5/3/6/12 g); written at once if started."""
        code = choose(range_g, RANGE_CODES, "range", self.chip, " g")
        if self.started:
            self.regs.write(DATA_FORMAT, FULL_RES | code)
        self._range_code, self.range_g = code, float(range_g)
        self._set_bits(code)

    def set_rate(self, rate_hz: float) -> None:
        """Change the output data rate (BW_RATE codes 0x6..0xF); written at once if started."""
        code = choose(rate_hz, RATE_CODES, "output data rate", self.chip, " Hz")
        if self.started:
            self.regs.write(BW_RATE, code)
        self._rate_code, self.rate_hz = code, float(rate_hz)

    def read_raw(self) -> tuple[int, int, int]:
        """One 6-byte burst from DATAX0 (little-endian X, Y, Z), signed counts at 2.9 mg/LSB."""
        if self.is_spi:
            try:
                rx = self.bus.xfer2([0xF2, 0, 0, 0, 0, 0, 0])  # READ | MB | DATAX0
            except OSError as exc:
                raise wrap_os_error(exc, self.regs.where(DATAX0), "6-byte burst read") from exc
            raw = bytes(rx[1:])
        else:
            try:
                raw = bytes(self.bus.read_i2c_block_data(self.address, DATAX0, 6))
            except OSError as exc:
                raise wrap_os_error(exc, self.regs.where(DATAX0), "6-byte burst read") from exc
        m, s = self._mask, self._sign
        x, y, z = _XYZ.unpack(raw)
        return ((x & m) ^ s) - s, ((y & m) ^ s) - s, ((z & m) ^ s) - s

    def data_ready(self) -> bool:
        """INT_SOURCE.DATA_READY (set whatever INT_ENABLE holds; cleared by reading the data)."""
        return bool(self.regs.read(INT_SOURCE) & INT_DATA_READY)

    def configure_fifo(self, watermark: int) -> None:
        """Put the 32-sample FIFO in stream mode with `watermark` (1..31); MEASURE is dropped while changing it."""
        if not isinstance(watermark, int) or not 1 <= watermark <= FIFO_DEPTH - 1:
            raise ValueError(f"{self.chip}: unsupported FIFO watermark {watermark!r}; allowed: 1..{FIFO_DEPTH - 1}")
        self.regs.write(POWER_CTL, 0x00)
        self.regs.write(FIFO_CTL, FIFO_STREAM | watermark)
        self.regs.write(INT_ENABLE, INT_WATERMARK | INT_OVERRUN)
        self.regs.write(POWER_CTL, MEASURE)
        self.watermark = watermark

    def fifo_entries(self) -> int:
        """Samples waiting in the FIFO (FIFO_STATUS.ENTRIES)."""
        return self.regs.read(FIFO_STATUS) & FIFO_ENTRIES_MASK

    def read_fifo(self) -> list[tuple[int, int, int]]:
        """Drain FIFO_STATUS.ENTRIES samples, one 6-byte burst each (each burst pops one entry).

        INT_SOURCE is read first; if OVERRUN was set the drained samples are attached to the FifoOverrun raised
        afterwards, because the gap makes them useless as a continuous series but they are still valid samples.
        """
        overrun = self.regs.read(INT_SOURCE) & INT_OVERRUN
        entries = self.regs.read(FIFO_STATUS) & FIFO_ENTRIES_MASK
        samples = [self.read_raw() for _ in range(entries)]
        if overrun:
            raise FifoOverrun(f"{self.regs.location}: FIFO overrun (INT_SOURCE 0x{INT_SOURCE:02X} bit 0): "
                              f"samples were lost; drained {entries}", samples)
        return samples

    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` is m/s^2 per count."""
        return {
            "chip": self.chip,
            "interface": "spi" if self.is_spi else "i2c",
            "address": None if self.is_spi else self.address,
            "range": self.range_g, "range_unit": "g",
            "rate_hz": self.rate_hz,
            "resolution": "full",
            "scale": STANDARD_GRAVITY / LSB_PER_G, "scale_unit": "m/s^2 per LSB",
        }
