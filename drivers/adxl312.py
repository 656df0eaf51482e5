"""ADXL312 3-axis digital accelerometer over I2C or SPI (mode 3).

Register map and start-up follow the Linux `adxl313` driver family (ADXL312 variant) and ADI no-OS
`adxl313.h`; see registers.md section 1. The ADXL312 has no soft-reset or part-ID registers beyond DEVID.
"""

from __future__ import annotations

import struct
import time
from typing import Any, Callable

from drivers._regs import I2cRegisters, SpiRegisters, check_not_floating, choose, spi_label
from drivers.contract import DataReady, KeepsConfiguration, Placement, Sensor, Wiring, chip_driver
from drivers.errors import FifoOverrun, SensorFault, WrongIdentity, wrap_os_error
from drivers.regmap import RegisterMap, Reg, ROBit, ROBits, RWBit, RWBits
from drivers.units import STANDARD_GRAVITY


class ADXL312Registers(RegisterMap):
    """ADXL312 register table (registers.md section 1; Linux adxl313.h)."""

    chip = "ADXL312"
    DEVID = Reg(0x00, access="r")
    OFSX, OFSY, OFSZ = Reg(0x1E), Reg(0x1F), Reg(0x20)
    BW_RATE, POWER_CTL, INT_ENABLE, INT_MAP = Reg(0x2C), Reg(0x2D), Reg(0x2E), Reg(0x2F)
    INT_SOURCE, DATA_FORMAT = Reg(0x30, access="r"), Reg(0x31)
    DATAX0, DATAX1, DATAY0 = Reg(0x32, access="r"), Reg(0x33, access="r"), Reg(0x34, access="r")
    DATAY1, DATAZ0, DATAZ1 = Reg(0x35, access="r"), Reg(0x36, access="r"), Reg(0x37, access="r")
    FIFO_CTL, FIFO_STATUS = Reg(0x38), Reg(0x39, access="r")

    rate = RWBits(4, BW_RATE, 0)
    low_power = RWBit(BW_RATE, 4)
    measure = RWBit(POWER_CTL, 3)
    i2c_disable = RWBit(POWER_CTL, 6)
    int_data_ready = RWBit(INT_ENABLE, 7)
    int_watermark = RWBit(INT_ENABLE, 1)
    int_overrun = RWBit(INT_ENABLE, 0)
    data_ready = ROBit(INT_SOURCE, 7)
    watermark_flag = ROBit(INT_SOURCE, 1)
    overrun = ROBit(INT_SOURCE, 0)
    self_test = RWBit(DATA_FORMAT, 7)
    full_res = RWBit(DATA_FORMAT, 3)
    justify = RWBit(DATA_FORMAT, 2)
    range = RWBits(2, DATA_FORMAT, 0)
    fifo_mode = RWBits(2, FIFO_CTL, 6)
    samples = RWBits(5, FIFO_CTL, 0)
    entries = ROBits(6, FIFO_STATUS, 0)


R = ADXL312Registers
DEVID_ADXL312 = 0xE5
FIFO_BYPASS, FIFO_STREAM = 0, 2
FIFO_DEPTH = 32
SELF_TEST_RANGE_CODE, SELF_TEST_RATE_CODE, SELF_TEST_RATE_HZ = 3, 0xA, 100.0
SELF_TEST_MIN_MG, SELF_TEST_MAX_MG = 300.0, 3400.0  # no-OS ADXL312_SELF_TEST_MIN/MAX_DEVIATION, Z axis

RANGE_CODES = {1.5: 0, 3: 1, 6: 2, 12: 3}
RATE_CODES = {6.25: 0x6, 12.5: 0x7, 25: 0x8, 50: 0x9, 100: 0xA, 200: 0xB, 400: 0xC, 800: 0xD, 1600: 0xE, 3200: 0xF}
LSB_PER_G = 345.0  # full resolution, every range (kernel 9.80665/345 m/s^2 per LSB; datasheet 2.9 mg/LSB typ)

SPI_MODE = 3
SPI_MAX_HZ = 5_000_000

_XYZ = struct.Struct("<HHH")


@chip_driver
class ADXL312(Sensor, DataReady, KeepsConfiguration):
    """ADXL312 in full-resolution mode; `bus` is an smbus2.SMBus-like object or, if it has `xfer2`, a SpiDev.

    Full resolution keeps 2.9 mg/LSB in every range, so only the number of valid bits (10..13) changes with
    the range; read paths sign-extend from that width so a chip that leaves the upper bits clear still decodes.
    """

    chip = "ADXL312"
    BUSES, SENSES, OPTIONS = ("i2c", "spi"), ("accel",), ("range_g", "rate_hz")
    SPI_MODE, SPI_MAX_HZ = SPI_MODE, SPI_MAX_HZ

    def __init__(self, bus: Any, address: int = 0x53, *, range_g: float = 12, rate_hz: float = 100,
                 cs: Any = None, sleep: Callable[[float], None] = time.sleep) -> None:
        self.is_spi = hasattr(bus, "xfer2")
        if self.is_spi:
            io: Any = SpiRegisters(bus, spi_label(bus, cs), self.chip, R.NAMES)
        else:
            io = I2cRegisters(bus, address, self.chip, R.NAMES)
        self.regs = R(io)
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
        regs = self.regs
        devid = regs.read(R.DEVID)
        if self.is_spi:
            check_not_floating(devid, regs.where(R.DEVID))
        if devid != DEVID_ADXL312:
            raise WrongIdentity(f"{regs.where(R.DEVID)}: read 0x{devid:02X}, expected 0x{DEVID_ADXL312:02X}")
        regs.put(R.POWER_CTL)
        regs.put(R.DATA_FORMAT, full_res=1, range=self._range_code)
        regs.put(R.BW_RATE, rate=self._rate_code)
        regs.put(R.INT_ENABLE)
        regs.put(R.FIFO_CTL, fifo_mode=FIFO_BYPASS)
        regs.put(R.POWER_CTL, measure=1)
        self.sleep(1.0 / self.rate_hz + 1.1e-3)  # turn-on time tau + 1.1 ms (datasheet p.4 note 5)
        self._discard_first_sample()
        self.started = True

    def configuration_lost(self) -> str | None:
        """The first configuration register that no longer reads what start() wrote (a power-on reset), or None."""
        return self.regs.lost()

    def _discard_first_sample(self) -> None:
        """Wait for DATA_READY and drop that sample: the turn-on time is only typical (no maximum is given),
        and until the first conversion the data registers hold zeros."""
        period = 1.0 / self.rate_hz
        step = min(period / 4, 5e-3)
        polls = int((period + 1.1e-3) / step) + 2
        for _ in range(polls):
            if self.regs.data_ready:
                self.read_raw()
                return
            self.sleep(step)
        raise SensorFault(f"{self.regs.where(R.INT_SOURCE)}: DATA_READY not set within "
                          f"{(polls * step + period) * 1e3:.1f} ms of MEASURE")

    def set_range(self, range_g: float) -> None:
        """Change the range (+-1.5/3/6/12 g); written at once if started."""
        code = choose(range_g, RANGE_CODES, "range", self.chip, " g")
        if self.started:
            self.regs.put(R.DATA_FORMAT, full_res=1, range=code)
        self._range_code, self.range_g = code, float(range_g)
        self._set_bits(code)

    def set_rate(self, rate_hz: float) -> None:
        """Change the output data rate (BW_RATE codes 0x6..0xF); written at once if started."""
        code = choose(rate_hz, RATE_CODES, "output data rate", self.chip, " Hz")
        if self.started:
            self.regs.put(R.BW_RATE, rate=code)
        self._rate_code, self.rate_hz = code, float(rate_hz)

    def read_raw(self) -> tuple[int, int, int]:
        """One 6-byte burst from DATAX0 (little-endian X, Y, Z), signed counts at 2.9 mg/LSB."""
        if self.is_spi:
            try:
                rx = self.bus.xfer2([0xF2, 0, 0, 0, 0, 0, 0])  # READ | MB | DATAX0
            except OSError as exc:
                raise wrap_os_error(exc, self.regs.where(R.DATAX0), "6-byte burst read") from exc
            raw = bytes(rx[1:])
        else:
            try:
                raw = bytes(self.bus.read_i2c_block_data(self.address, 0x32, 6))  # DATAX0
            except OSError as exc:
                raise wrap_os_error(exc, self.regs.where(R.DATAX0), "6-byte burst read") from exc
        m, s = self._mask, self._sign
        x, y, z = _XYZ.unpack(raw)
        return ((x & m) ^ s) - s, ((y & m) ^ s) - s, ((z & m) ^ s) - s

    def data_ready(self) -> bool:
        """INT_SOURCE.DATA_READY (set whatever INT_ENABLE holds; cleared by reading the data)."""
        return bool(self.regs.data_ready)

    def configure_fifo(self, watermark: int) -> None:
        """Put the 32-sample FIFO in stream mode with `watermark` (1..31); MEASURE is dropped while changing it."""
        if not isinstance(watermark, int) or not 1 <= watermark <= FIFO_DEPTH - 1:
            raise ValueError(f"{self.chip}: unsupported FIFO watermark {watermark!r}; allowed: 1..{FIFO_DEPTH - 1}")
        regs = self.regs
        regs.put(R.POWER_CTL)
        regs.put(R.FIFO_CTL, fifo_mode=FIFO_STREAM, samples=watermark)
        regs.put(R.INT_ENABLE, int_watermark=1, int_overrun=1)
        regs.put(R.POWER_CTL, measure=1)
        self.watermark = watermark

    def fifo_entries(self) -> int:
        """Samples waiting in the FIFO (FIFO_STATUS.ENTRIES)."""
        return self.regs.entries

    def read_fifo(self) -> list[tuple[int, int, int]]:
        """Drain FIFO_STATUS.ENTRIES samples, one 6-byte burst each (each burst pops one entry).

        INT_SOURCE is read first; if OVERRUN was set the drained samples are attached to the FifoOverrun raised
        afterwards, because the gap makes them useless as a continuous series but they are still valid samples.
        """
        overrun = self.regs.overrun
        entries = self.regs.entries
        samples = [self.read_raw() for _ in range(entries)]
        if overrun:
            raise FifoOverrun(f"{self.regs.where(R.INT_SOURCE)}: FIFO overrun (bit 0): samples were lost; "
                              f"drained {entries}", samples)
        return samples

    def self_test(self, samples: int = 10) -> float:
        """Z-axis self-test response in mg; SensorFault outside 300..3400 mg (ADI no-OS limits for ADXL312).

        Runs at +-12 g and 100 Hz like no-OS, averages `samples` readings with SELF_TEST off and on after
        5 output periods of settling each (datasheet: 4 tau), then restores the configured range and rate.
        """
        period = 1.0 / SELF_TEST_RATE_HZ
        regs = self.regs
        regs.put(R.POWER_CTL)
        regs.put(R.DATA_FORMAT, full_res=1, range=SELF_TEST_RANGE_CODE)
        regs.put(R.BW_RATE, rate=SELF_TEST_RATE_CODE)
        regs.put(R.POWER_CTL, measure=1)
        saved_bits = self._mask, self._sign
        self._set_bits(SELF_TEST_RANGE_CODE)
        try:
            z_off = self._mean_z(samples, period)
            regs.put(R.DATA_FORMAT, self_test=1, full_res=1, range=SELF_TEST_RANGE_CODE)
            z_on = self._mean_z(samples, period)
        finally:
            self._mask, self._sign = saved_bits
            regs.put(R.DATA_FORMAT, full_res=1, range=self._range_code)
            regs.put(R.BW_RATE, rate=self._rate_code)
            self.sleep(5 * period)
        change_mg = (z_on - z_off) * 1000.0 / LSB_PER_G
        if not SELF_TEST_MIN_MG < change_mg < SELF_TEST_MAX_MG:
            raise SensorFault(f"{self.regs.where(R.DATA_FORMAT)}: self-test Z change {change_mg:.0f} mg outside "
                              f"{SELF_TEST_MIN_MG:.0f}..{SELF_TEST_MAX_MG:.0f} mg")
        return change_mg

    def _mean_z(self, samples: int, period: float) -> float:
        self.sleep(5 * period)
        total = 0
        for _ in range(samples):
            total += self.read_raw()[2]
            self.sleep(period)
        return total / samples

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

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "ADXL312":
        bus = wiring.bus_for(placement, SPI_MODE, SPI_MAX_HZ)
        address = 0x53 if placement.address is None else placement.address
        return cls(bus, address, cs=placement.cs, sleep=wiring.sleep, **placement.options)
