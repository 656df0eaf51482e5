"""LSM6DSO 6-axis accelerometer + gyroscope over I2C or SPI, read through its tagged FIFO.

Register facts: Linux `st_lsm6dsx_core.c` / `st_lsm6dsx_buffer.c` and ST's `lsm6dso_reg.h` (drivers/VERIFIED.md).
A chip family is a base class (`LSM6DSFamily`, the registers and tables shared by ST's tagged-FIFO parts) and a
small per-chip subclass with its WHO_AM_I (Adafruit LSM6DS style).

Why the FIFO: at 100+ Hz a host that polls output registers must hit every sample period; with the FIFO in
continuous mode the chip keeps every sample, tagged by sensor, and one status read plus one burst per four words
drains both sensors. The sampler's `read_raw()` takes the newest sample of each sensor from what was drained
(a point reading at most one output period old); `read_fifo()` hands over everything for a caller that wants
the full stream.
"""

from __future__ import annotations

import math
import struct
import time
from typing import Any, Callable

from drivers._regs import I2cRegisters, StSpiRegisters, check_not_floating, choose, spi_label
from drivers.contract import DataReady, KeepsConfiguration, Part, Placement, Sensor, Thermometer, Wiring, chip_driver
from drivers.errors import FifoOverrun, SensorFault, WrongIdentity
from drivers.regmap import RegisterMap, Reg, ROBit, ROBits, RWBit, RWBits
from drivers.units import STANDARD_GRAVITY


class LSM6DSRegisters(RegisterMap):
    """Registers of ST's tagged-FIFO LSM6DS parts (LSM6DSO, LSM6DSOX, ...)."""

    chip = "LSM6DS"
    FIFO_CTRL1, FIFO_CTRL2, FIFO_CTRL3, FIFO_CTRL4 = Reg(0x07), Reg(0x08), Reg(0x09), Reg(0x0A)
    INT1_CTRL, INT2_CTRL, WHO_AM_I = Reg(0x0D), Reg(0x0E), Reg(0x0F, access="r")
    CTRL1_XL, CTRL2_G, CTRL3_C, CTRL4_C = Reg(0x10), Reg(0x11), Reg(0x12), Reg(0x13)
    CTRL8_XL = Reg(0x17)
    STATUS_REG = Reg(0x1E, access="r")
    OUT_TEMP_L, OUTX_L_G, OUTX_L_A = Reg(0x20, access="r"), Reg(0x22, access="r"), Reg(0x28, access="r")
    FIFO_STATUS1, FIFO_STATUS2 = Reg(0x3A, access="r"), Reg(0x3B, access="r")
    INTERNAL_FREQ_FINE = Reg(0x63, access="r")
    FIFO_DATA_OUT_TAG = Reg(0x78, access="r")

    wtm = RWBits(8, FIFO_CTRL1, 0)
    wtm8 = RWBit(FIFO_CTRL2, 0)
    stop_on_wtm = RWBit(FIFO_CTRL2, 7)
    bdr_gy = RWBits(4, FIFO_CTRL3, 4)
    bdr_xl = RWBits(4, FIFO_CTRL3, 0)
    odr_ts_batch = RWBits(2, FIFO_CTRL4, 6)
    odr_t_batch = RWBits(2, FIFO_CTRL4, 4)
    fifo_mode = RWBits(3, FIFO_CTRL4, 0)
    int1_fifo_th = RWBit(INT1_CTRL, 3)
    odr_xl = RWBits(4, CTRL1_XL, 4)
    fs_xl = RWBits(2, CTRL1_XL, 2)
    lpf2_xl_en = RWBit(CTRL1_XL, 1)
    odr_g = RWBits(4, CTRL2_G, 4)
    fs_g = RWBits(2, CTRL2_G, 2)
    fs_125 = RWBit(CTRL2_G, 1)
    boot = RWBit(CTRL3_C, 7)
    bdu = RWBit(CTRL3_C, 6)
    if_inc = RWBit(CTRL3_C, 2)
    sw_reset = RWBit(CTRL3_C, 0)
    i2c_disable = RWBit(CTRL4_C, 2)
    xl_fs_mode = RWBit(CTRL8_XL, 1)
    tda, gda, xlda = ROBit(STATUS_REG, 2), ROBit(STATUS_REG, 1), ROBit(STATUS_REG, 0)
    fifo_wtm_ia = ROBit(FIFO_STATUS2, 7)
    fifo_ovr_ia = ROBit(FIFO_STATUS2, 6)
    fifo_full_ia = ROBit(FIFO_STATUS2, 5)
    fifo_ovr_latched = ROBit(FIFO_STATUS2, 3)
    diff_fifo_high = ROBits(2, FIFO_STATUS2, 0)
    tag_sensor = ROBits(5, FIFO_DATA_OUT_TAG, 3)


R = LSM6DSRegisters
ODR_CODES = {12.5: 1, 26: 2, 52: 3, 104: 4, 208: 5, 416: 6, 833: 7, 1666: 8, 3332: 9, 6664: 10}
ACCEL_FS = {2: (0, 0.061), 4: (2, 0.122), 8: (3, 0.244), 16: (1, 0.488)}     # g -> (FS_XL, mg/LSB)
GYRO_FS = {125: (0, 1, 4.375), 250: (0, 0, 8.75), 500: (1, 0, 17.5), 1000: (2, 0, 35.0),
           2000: (3, 0, 70.0)}                                                # dps -> (FS_G, FS_125, mdps/LSB)
FREQ_FINE_STEP = 0.0015             # INTERNAL_FREQ_FINE: output rates are nominal x (1 + 0.0015 x value)
FIFO_BYPASS, FIFO_CONTINUOUS = 0, 6
TAG_GYRO, TAG_ACCEL = 0x01, 0x02
WORD = 7                            # tag byte + 3 x 16-bit little-endian
WORDS_PER_BURST = 4                 # 28 bytes: within the SMBus 32-byte block (Linux MAX_TAGGED_WORD_LEN)
RESET_WAIT_S = BOOT_WAIT_S = 0.05   # Linux st_lsm6dsx_init_device: msleep(50) after SW_RESET and after BOOT
TURN_ON_S = 0.07                    # gyro turn-on before the first sample kept [U]
SPI_MODE, SPI_MAX_HZ = 3, 10_000_000

_XYZ = struct.Struct("<hhh")


class LSM6DSFamily(Part, Thermometer, KeepsConfiguration):
    """Accelerometer + gyroscope at one output rate, both batched into the FIFO in continuous mode.

    `accel` and `gyro` are the two sensor views a board reads; the chip itself is the part that is started.
    """

    chip = "LSM6DS"
    CHIP_ID = 0x00
    BUSES, SENSES, OPTIONS = ("i2c", "spi"), ("accel", "gyro"), ("odr_hz", "accel_range_g", "gyro_range_dps")

    def __init__(self, bus: Any, address: int = 0x6A, *, cs: Any = None, odr_hz: float = 104,
                 accel_range_g: int = 4, gyro_range_dps: int = 2000,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        self.is_spi = hasattr(bus, "xfer2")
        io: Any = (StSpiRegisters(bus, spi_label(bus, cs), self.chip, R.NAMES) if self.is_spi
                   else I2cRegisters(bus, address, self.chip, R.NAMES))
        self.regs, self.bus, self.address, self.sleep = R(io), bus, address, sleep
        self._odr = choose(odr_hz, ODR_CODES, "output data rate", self.chip, " Hz")
        self._xl = choose(accel_range_g, ACCEL_FS, "accelerometer range", self.chip, " g")
        self._g = choose(gyro_range_dps, GYRO_FS, "gyroscope range", self.chip, " dps")
        self.odr_hz, self.accel_range_g, self.gyro_range_dps = float(odr_hz), accel_range_g, gyro_range_dps
        self._pending: dict[int, list] = {TAG_ACCEL: [], TAG_GYRO: []}
        self._last = {TAG_ACCEL: (0, 0, 0), TAG_GYRO: (0, 0, 0)}
        self.overruns = 0
        self.output_hz = self.odr_hz      # the rate the part really samples at: read from its trim by start()
        self.started = False
        self.accel, self.gyro = _View(self, "accel", TAG_ACCEL), _View(self, "gyro", TAG_GYRO)

    def start(self) -> None:
        """WHO_AM_I -> SW_RESET -> BOOT -> BDU -> oscillator trim -> FIFO batching -> ODR/FS -> continuous FIFO ->
        drop turn-on data. The trim (INTERNAL_FREQ_FINE) says the rate the part really samples at (`output_hz`),
        which the sampler's grid must follow: a grid at the nominal rate beats against a part a few tenths of a
        per cent off it."""
        regs = self.regs
        who = regs.read(R.WHO_AM_I)
        if self.is_spi:
            check_not_floating(who, regs.where(R.WHO_AM_I))
        if who != self.CHIP_ID:
            raise WrongIdentity(f"{regs.where(R.WHO_AM_I)}: read 0x{who:02X}, expected 0x{self.CHIP_ID:02X}")
        regs.put(R.CTRL3_C, sw_reset=1, if_inc=1)
        self.sleep(RESET_WAIT_S)
        if regs.sw_reset:
            raise SensorFault(f"{regs.where(R.CTRL3_C)}: SW_RESET still set {RESET_WAIT_S * 1e3:g} ms after reset")
        regs.put(R.CTRL3_C, boot=1, if_inc=1)
        self.sleep(BOOT_WAIT_S)
        regs.put(R.CTRL3_C, bdu=1, if_inc=1)
        self.output_hz = self.odr_hz * (1.0 + FREQ_FINE_STEP * _signed_byte(regs.read(R.INTERNAL_FREQ_FINE)))
        regs.put(R.FIFO_CTRL3, bdr_gy=self._odr, bdr_xl=self._odr)
        regs.put(R.CTRL1_XL, odr_xl=self._odr, fs_xl=ACCEL_FS[self.accel_range_g][0])
        fs_g, fs_125, _ = GYRO_FS[self.gyro_range_dps]
        regs.put(R.CTRL2_G, odr_g=self._odr, fs_g=fs_g, fs_125=fs_125)
        regs.put(R.FIFO_CTRL4, fifo_mode=FIFO_CONTINUOUS)
        self.sleep(TURN_ON_S)
        self.read_fifo(strict=False)
        self._pending = {TAG_ACCEL: [], TAG_GYRO: []}
        self._wait_first_samples()
        self.started = True

    def configuration_lost(self) -> str | None:
        """The first configuration register that no longer reads what start() wrote (a power-on reset), or None."""
        return self.regs.lost()

    def _wait_first_samples(self) -> None:
        period = 1.0 / self.output_hz
        for _ in range(20):
            self._drain()
            if self._pending[TAG_ACCEL] and self._pending[TAG_GYRO]:
                return
            self.sleep(period / 2)
        raise SensorFault(f"{self.regs.where(R.FIFO_STATUS1)}: no accelerometer and gyroscope samples in the "
                          f"FIFO within {10 * period * 1e3:.0f} ms of enabling {self.odr_hz:g} Hz")

    # -- FIFO ----------------------------------------------------------------------------------------------
    def fifo_level(self) -> tuple[int, bool]:
        """(words waiting, overrun since last read): FIFO_STATUS1..2 in one 2-byte burst."""
        low, high = self.regs.read_block(R.FIFO_STATUS1, 2)
        return low | (R.diff_fifo_high.get(high) << 8), bool(R.fifo_ovr_latched.get(high))

    def read_fifo(self, strict: bool = True) -> dict[str, list[tuple[int, int, int]]]:
        """Drain every waiting word: {"accel": [...], "gyro": [...]} oldest first.

        A FIFO that overflowed lost its oldest words; with `strict` that raises FifoOverrun carrying what was
        drained (valid samples, but not a continuous series)."""
        words, overrun = self.fifo_level()
        out: dict[str, list] = {"accel": [], "gyro": []}
        while words > 0:
            n = min(words, WORDS_PER_BURST)
            raw = self.regs.read_block(R.FIFO_DATA_OUT_TAG, n * WORD)
            for i in range(0, n * WORD, WORD):
                tag = raw[i] >> 3
                if tag == TAG_ACCEL:
                    out["accel"].append(_XYZ.unpack_from(raw, i + 1))
                elif tag == TAG_GYRO:
                    out["gyro"].append(_XYZ.unpack_from(raw, i + 1))
            words -= n
        if overrun:
            self.overruns += 1
            if strict:
                raise FifoOverrun(f"{self.regs.where(R.FIFO_STATUS2)}: FIFO overrun (FIFO_OVR_LATCHED): "
                                  f"the oldest samples were overwritten", out)
        return out

    def _drain(self) -> None:
        got = self.read_fifo(strict=False)
        self._pending[TAG_ACCEL] += got["accel"]
        self._pending[TAG_GYRO] += got["gyro"]

    def newest(self, tag: int) -> tuple[int, int, int]:
        """The newest drained sample of one sensor (draining first if none is waiting); the older ones are
        dropped. With nothing new the last sample is repeated, as an output register would be."""
        pending = self._pending[tag]
        if not pending:
            self._drain()
            pending = self._pending[tag]
        if pending:
            self._last[tag] = pending[-1]
            pending.clear()
        return self._last[tag]

    def waiting(self, tag: int) -> bool:
        if not self._pending[tag]:
            self._drain()
        return bool(self._pending[tag])

    def read_temperature(self) -> float:
        """OUT_TEMP: 256 LSB/degC, 0 at 25 degC (ST lsm6dso_from_lsb_to_celsius)."""
        raw = self.regs.read_block(R.OUT_TEMP_L, 2)
        return 25.0 + int.from_bytes(raw, "little", signed=True) / 256.0

    # -- description ---------------------------------------------------------------------------------------
    def sensor(self, kind: str) -> Sensor:
        if kind == "accel":
            return self.accel
        if kind == "gyro":
            return self.gyro
        return super().sensor(kind)

    def scale(self, kind: str) -> float:
        if kind == "accel":
            return ACCEL_FS[self.accel_range_g][1] * 1e-3 * STANDARD_GRAVITY
        return math.radians(GYRO_FS[self.gyro_range_dps][2] * 1e-3)

    def settings(self) -> dict:
        return {"chip": self.chip, "interface": "spi" if self.is_spi else "i2c",
                "address": None if self.is_spi else self.address, "odr_hz": self.odr_hz,
                "output_hz": self.output_hz, "fifo": "continuous",
                "accel_range_g": self.accel_range_g, "gyro_range_dps": self.gyro_range_dps,
                "fifo_overruns": self.overruns}

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "LSM6DSFamily":
        bus = wiring.bus_for(placement, SPI_MODE, SPI_MAX_HZ)
        address = 0x6A if placement.address is None else placement.address
        return cls(bus, address, cs=placement.cs, sleep=wiring.sleep, **placement.options)


def _signed_byte(value: int) -> int:
    return value - 256 if value & 0x80 else value


class _View(Sensor, DataReady, Thermometer):
    """One of the chip's two sensors, as the board's accel or gyro triad."""

    def __init__(self, chip: LSM6DSFamily, kind: str, tag: int) -> None:
        self.part, self.kind, self.tag = chip, kind, tag
        self.chip = f"{chip.chip} {kind}"
        self.SENSES = (kind,)

    def start(self) -> None:
        if not self.part.started:
            self.part.start()

    def read_raw(self) -> tuple[int, int, int]:
        return self.part.newest(self.tag)

    def data_ready(self) -> bool:
        """A sample of this sensor is waiting in the FIFO (or already drained and not yet read)."""
        return self.part.waiting(self.tag)

    def read_temperature(self) -> float:
        return self.part.read_temperature()

    def settings(self) -> dict:
        unit = "m/s^2 per LSB" if self.kind == "accel" else "rad/s per LSB"
        rng = (self.part.accel_range_g, "g") if self.kind == "accel" else (self.part.gyro_range_dps, "deg/s")
        return {**self.part.settings(), "chip": self.part.chip, "sensor": self.kind, "range": float(rng[0]),
                "range_unit": rng[1], "rate_hz": self.part.output_hz, "scale": self.part.scale(self.kind),
                "scale_unit": unit}

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "_View":
        raise TypeError("an LSM6DS sensor view is built by its chip, not placed on a board")


@chip_driver
class LSM6DSO(LSM6DSFamily):
    chip = "LSM6DSO"
    CHIP_ID = 0x6C
