"""Minimal register-level chip emulators written from the datasheets, independently of `fixtures/chips/`.

Why a second set: our own emulators were written from the same notes as the drivers, so a shared misreading of a
datasheet would pass unnoticed. These were written only from /work/shared/reference/registers.md (preferring its
[K]/[D] items) and datasheet pages found with the search tool; every behaviour the sources leave open ([U]) is a
constructor parameter so a test can try both plausible readings.

Buses are duck-typed: `I2CBus` has the `smbus2.SMBus` methods and models each call as the I2C transactions it makes
on the wire (pointer write, then a repeated-start read); `SpiPort` has `xfer2(list)` (one chip-select assertion per
call) and the spidev attributes `mode` and `max_speed_hz`. Bus traffic costs wire time on a `ManualClock`.
"""

from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

EREMOTEIO = 121  # errno EREMOTEIO, what Linux i2c-dev returns when the address is not acknowledged


class ManualClock:
    """Virtual time advanced only by `sleep`/`advance` and by bus traffic."""

    def __init__(self, start_s: float = 1.0) -> None:
        self.t = float(start_s)

    def now(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        if dt < 0:
            raise ValueError(f"negative sleep {dt}")
        self.t += float(dt)

    advance = sleep


def _odd_parity_bit(word: int) -> int:
    """The bit that makes `word | bit` have an odd number of ones."""
    return 0 if bin(word).count("1") % 2 else 1


def _s16_bytes_be(value: int) -> list[int]:
    v = int(value) & 0xFFFF
    return [v >> 8, v & 0xFF]


def _clip(value: float, lo: int, hi: int) -> int:
    return int(max(lo, min(hi, round(value))))


# --------------------------------------------------------------------------------------------------------- I2C ---


class I2CDevice:
    """A register-pointer I2C slave: a write sets the pointer (first byte) then stores data; a read auto-increments."""

    def __init__(self, clock: ManualClock) -> None:
        self.clock = clock
        self.pointer = 0
        self.violations: list[str] = []

    def i2c_write(self, data: Sequence[int]) -> None:
        raise NotImplementedError

    def i2c_read(self, n: int) -> list[int]:
        raise NotImplementedError

    def acknowledges(self) -> bool:
        return True


class I2CBus:
    """smbus2.SMBus look-alike; an address with no device, or a device that stops acknowledging, raises OSError(121)."""

    SECONDS_PER_BYTE = 9 / 400e3

    def __init__(self, clock: ManualClock) -> None:
        self.clock = clock
        self.devices: dict[int, I2CDevice] = {}
        self.log: list[tuple] = []

    def attach(self, address: int, device: I2CDevice) -> I2CDevice:
        self.devices[address] = device
        return device

    def _dev(self, addr: int) -> I2CDevice:
        dev = self.devices.get(addr)
        if dev is None or not dev.acknowledges():
            raise OSError(EREMOTEIO, f"Remote I/O error: no ACK from I2C address 0x{addr:02X}")
        return dev

    def _write(self, addr: int, data: Sequence[int]) -> None:
        dev = self._dev(addr)
        self.clock.advance(self.SECONDS_PER_BYTE * (len(data) + 1))
        self.log.append(("w", addr, list(data)))
        dev.i2c_write([int(b) & 0xFF for b in data])

    def _read(self, addr: int, n: int) -> list[int]:
        dev = self._dev(addr)
        self.clock.advance(self.SECONDS_PER_BYTE * (n + 1))
        out = dev.i2c_read(n)
        self.log.append(("r", addr, list(out)))
        return out

    # smbus2.SMBus API -----------------------------------------------------------------------------------------
    def read_byte(self, i2c_addr: int, force=None) -> int:
        return self._read(i2c_addr, 1)[0]

    def write_byte(self, i2c_addr: int, value: int, force=None) -> None:
        self._write(i2c_addr, [value])

    def write_quick(self, i2c_addr: int, force=None) -> None:
        self._write(i2c_addr, [])

    def read_byte_data(self, i2c_addr: int, register: int, force=None) -> int:
        self._write(i2c_addr, [register])
        return self._read(i2c_addr, 1)[0]

    def write_byte_data(self, i2c_addr: int, register: int, value: int, force=None) -> None:
        self._write(i2c_addr, [register, value])

    def read_word_data(self, i2c_addr: int, register: int, force=None) -> int:
        self._write(i2c_addr, [register])
        lo, hi = self._read(i2c_addr, 2)
        return lo | (hi << 8)  # SMBus words are little-endian on the wire

    def write_word_data(self, i2c_addr: int, register: int, value: int, force=None) -> None:
        self._write(i2c_addr, [register, value & 0xFF, (value >> 8) & 0xFF])

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int, force=None) -> list[int]:
        if not 0 < length <= 32:
            raise ValueError("Desired block length over 32 bytes")  # smbus2 limit
        self._write(i2c_addr, [register])
        return self._read(i2c_addr, length)

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: Sequence[int], force=None) -> None:
        if len(data) > 32:
            raise ValueError("Data length cannot exceed 32 bytes")
        self._write(i2c_addr, [register, *data])

    def i2c_rdwr(self, *i2c_msgs) -> None:
        for msg in i2c_msgs:
            if msg.flags & 0x0001:  # I2C_M_RD
                data = self._read(msg.addr, msg.len)
                ctypes.memmove(msg.buf, bytes(data), msg.len)
            else:
                self._write(msg.addr, list(msg))

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        pass


# ----------------------------------------------------------------------------------------------------- ADXL312 ---


class ADXL312(I2CDevice):
    """ADXL312 on I2C. Sources: registers.md §1 (kernel adxl313 tables, no-OS bit fields, ADXL312 Rev. B p.4).

    Physical input: `accel_g` (3-vector, g); `turn_on_extra_s` models a part slower than the typical turn-on time.
    2.9 mg/LSB in full resolution [D]; in 10-bit mode the LSB doubles per
    range step (2.9, 5.8, 11.6, 23.2 mg). Data registers are live only in MEASURE mode; the first sample lands one
    turn-on time (tau + 1.1 ms) after MEASURE is set [D footnote 5].
    """

    DEVID, OFSX, BW_RATE, POWER_CTL, INT_SOURCE, DATA_FORMAT, DATAX0, FIFO_CTL, FIFO_STATUS = (
        0x00, 0x1E, 0x2C, 0x2D, 0x30, 0x31, 0x32, 0x38, 0x39)
    READABLE = {0x00, 0x1E, 0x1F, 0x20, 0x24, 0x25, 0x26, 0x27, *range(0x2C, 0x3A)}
    WRITABLE = {0x1E, 0x1F, 0x20, 0x24, 0x25, 0x26, 0x27, 0x2C, 0x2D, 0x2E, 0x2F, 0x31, 0x38}
    LSB_G = 0.0029
    ODR_HZ = {6: 6.25, 7: 12.5, 8: 25, 9: 50, 10: 100, 11: 200, 12: 400, 13: 800, 14: 1600, 15: 3200}

    def __init__(self, clock: ManualClock, devid: int = 0xE5, accel_g=(0.0, 0.0, 1.0),
                 turn_on_extra_s: float = 0.0) -> None:
        super().__init__(clock)
        self.turn_on_extra_s = turn_on_extra_s  # the datasheet turn-on time tau + 1.1 ms is typical, not maximum
        self.regs = [0] * 0x40
        self.regs[self.DEVID] = devid
        self.regs[self.BW_RATE] = 0x0A
        self.regs[self.INT_SOURCE] = 0x02
        self.accel_g = np.asarray(accel_g, float)
        self.measure_since: float | None = None
        self.samples_taken = 0
        self.fifo: list[list[int]] = []

    # physical model -------------------------------------------------------------------------------------------
    def counts_for(self, accel_g) -> list[int]:
        """Right-justified signed counts the chip would output for `accel_g` at the current DATA_FORMAT."""
        fmt = self.regs[self.DATA_FORMAT]
        rng = fmt & 0x03
        ofs = [np.int8(np.uint8(self.regs[self.OFSX + i])) for i in range(3)]
        if fmt & 0x08:
            bits, lsb = 10 + rng, self.LSB_G
        else:
            bits, lsb = 10, self.LSB_G * (1 << rng)
        lo, hi = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
        return [_clip(a / lsb + int(o) * 4 * self.LSB_G / lsb, lo, hi) for a, o in zip(accel_g, ofs)]

    def _encode(self, counts: list[int]) -> list[int]:
        fmt = self.regs[self.DATA_FORMAT]
        bits = 10 + (fmt & 3) if fmt & 0x08 else 10
        out = []
        for c in counts:
            v = (c << (16 - bits)) if fmt & 0x04 else c  # JUSTIFY: left-justified, MSB at bit 15
            v &= 0xFFFF
            out += [v & 0xFF, v >> 8]  # little-endian
        return out

    def _update(self) -> None:
        if self.measure_since is None:
            return
        odr = self.ODR_HZ.get(self.regs[self.BW_RATE] & 0x0F, 100.0)
        first = self.measure_since + 1.0 / odr + 1.1e-3 + self.turn_on_extra_s
        if self.clock.now() < first:
            return
        n = int((self.clock.now() - first) * odr) + 1
        if n <= self.samples_taken:
            return
        new = min(n - self.samples_taken, 33)
        self.samples_taken = n
        sample = self._encode(self.counts_for(self.accel_g))
        mode = self.regs[self.FIFO_CTL] >> 6
        if mode == 0:
            self.regs[self.DATAX0:self.DATAX0 + 6] = sample
        else:
            for _ in range(new):
                if len(self.fifo) < 32:
                    self.fifo.append(sample)
                else:
                    self.regs[self.INT_SOURCE] |= 0x01
                    if mode == 2:
                        self.fifo.pop(0)
                        self.fifo.append(sample)
            self.regs[self.DATAX0:self.DATAX0 + 6] = self.fifo[0]
        self.regs[self.INT_SOURCE] |= 0x80

    # bus --------------------------------------------------------------------------------------------------------
    def acknowledges(self) -> bool:
        return not (self.regs[self.POWER_CTL] & 0x40)  # I2C_DISABLE: the I2C port stops answering

    def i2c_write(self, data: Sequence[int]) -> None:
        if not data:
            return
        self.pointer = data[0] & 0x3F
        for value in data[1:]:
            reg = self.pointer
            if reg not in self.WRITABLE:
                self.violations.append(f"write 0x{value:02X} to non-writable register 0x{reg:02X}")
            else:
                self._store(reg, value)
            self.pointer = (self.pointer + 1) & 0x3F

    def _store(self, reg: int, value: int) -> None:
        self._update()
        if reg == self.POWER_CTL:
            was, now = self.regs[reg] & 0x08, value & 0x08
            if now and not was:
                self.measure_since, self.samples_taken = self.clock.now(), 0
            elif was and not now:
                self.measure_since = None
        self.regs[reg] = value

    def i2c_read(self, n: int) -> list[int]:
        self._update()
        out, touched_data = [], False
        for _ in range(n):
            reg = self.pointer
            if reg not in self.READABLE:
                self.violations.append(f"read of reserved register 0x{reg:02X}")
                out.append(0)
            elif reg == self.FIFO_STATUS:
                out.append(len(self.fifo) & 0x3F)
            else:
                out.append(self.regs[reg])
            touched_data |= self.DATAX0 <= reg < self.DATAX0 + 6
            self.pointer = (self.pointer + 1) & 0x3F
        if touched_data:  # DATA_READY and OVERRUN are cleared by reading the data registers (ADXL345 family)
            self.regs[self.INT_SOURCE] &= ~0x81 & 0xFF
            if self.fifo:
                self.fifo.pop(0)
                if self.fifo:
                    self.regs[self.DATAX0:self.DATAX0 + 6] = self.fifo[0]
                    self.regs[self.INT_SOURCE] |= 0x80
        return out


# ----------------------------------------------------------------------------------------------------- ITG3200 ---


class ITG3200(I2CDevice):
    """ITG-3200. Sources: registers.md §3 (kernel itg3200.h/core, PS rev 1.4 §8).

    Register address bit 7 is ignored (the kernel sets it for burst access). Gyro 14.375 LSB/(deg/s) with FS_SEL = 3,
    the only setting the datasheet allows; with any other FS_SEL this emulator outputs a deliberately different scale
    (operation is unspecified there). Temperature raw = 280*(T - 35) - 13200.
    `who_am_i`: power-up WHO_AM_I (0x68; a forum report shows 0x69 with AD0 low).
    `status_needs_enable`: [U] whether INT_STATUS.RAW_DATA_RDY is set only when INT_CFG.RAW_RDY_EN is set.
    """

    WHO_AM_I, SMPLRT_DIV, DLPF_FS, INT_CFG, INT_STATUS, TEMP_OUT_H, PWR_MGM = 0x00, 0x15, 0x16, 0x17, 0x1A, 0x1B, 0x3E
    WRITABLE = {0x00, 0x15, 0x16, 0x17, 0x3E}
    READABLE = {0x00, 0x15, 0x16, 0x17, 0x1A, *range(0x1B, 0x23), 0x3E}
    LSB_PER_DPS = 14.375

    def __init__(self, clock: ManualClock, who_am_i: int = 0x68, rate_dps=(0.0, 0.0, 0.0), temp_c: float = 25.0,
                 status_needs_enable: bool = False) -> None:
        super().__init__(clock)
        self.power_up_who = who_am_i
        self.rate_dps = np.asarray(rate_dps, float)
        self.temp_c = temp_c
        self.status_needs_enable = status_needs_enable
        self._reset()

    def _reset(self) -> None:
        self.regs = [0] * 0x80
        self.regs[self.WHO_AM_I] = self.power_up_who
        self.sampling_since = self.clock.now()
        self.samples_taken = 0
        self.pll_ready_at, self.pll_flagged = self.clock.now(), False
        self.resets = getattr(self, "resets", -1) + 1

    def sample_rate_hz(self) -> float:
        internal = 8000.0 if (self.regs[self.DLPF_FS] & 0x07) == 0 else 1000.0
        return internal / (self.regs[self.SMPLRT_DIV] + 1)

    def counts_for(self, rate_dps, temp_c: float) -> list[int]:
        fs_sel = (self.regs[self.DLPF_FS] >> 3) & 3
        scale = self.LSB_PER_DPS if fs_sel == 3 else self.LSB_PER_DPS * (4 - fs_sel) * 1.7
        temp = _clip(280.0 * (temp_c - 35.0) - 13200.0, -32768, 32767)
        return [temp, *(_clip(r * scale, -32768, 32767) for r in rate_dps)]

    def _flag(self, bit: int) -> None:
        if not self.status_needs_enable or self.regs[self.INT_CFG] & bit:
            self.regs[self.INT_STATUS] |= bit

    def _update(self) -> None:
        if not self.pll_flagged and self.clock.now() >= self.pll_ready_at:
            self.pll_flagged = True
            self._flag(0x04)
        if self.regs[self.PWR_MGM] & 0x40:  # SLEEP
            return
        fs = self.sample_rate_hz()
        n = int((self.clock.now() - self.sampling_since) * fs)
        if n <= self.samples_taken:
            return
        self.samples_taken = n
        values = self.counts_for(self.rate_dps, self.temp_c)
        standby = self.regs[self.PWR_MGM]
        for i, v in enumerate(values):
            if i and standby & (0x40 >> i):  # STBY_XG/YG/ZG at b5/b4/b3
                continue
            self.regs[0x1B + 2 * i:0x1D + 2 * i] = _s16_bytes_be(v)
        self._flag(0x01)

    def i2c_write(self, data: Sequence[int]) -> None:
        if not data:
            return
        self.pointer = data[0] & 0x7F
        self._update()
        for value in data[1:]:
            reg = self.pointer
            if reg not in self.WRITABLE:
                self.violations.append(f"write 0x{value:02X} to non-writable register 0x{reg:02X}")
            elif reg == self.PWR_MGM and value & 0x80:
                self._reset()
                return
            else:
                if reg == self.WHO_AM_I:
                    value = (value & 0x7E) | (self.regs[reg] & 0x81)
                if reg == self.PWR_MGM and (value & 0x07) != (self.regs[reg] & 0x07):
                    self.pll_ready_at, self.pll_flagged = self.clock.now() + 1e-3, False
                    self.regs[self.INT_STATUS] &= ~0x04 & 0xFF
                if reg in (self.SMPLRT_DIV, self.DLPF_FS) or (reg == self.PWR_MGM and (self.regs[reg] ^ value) & 0x40):
                    self.sampling_since, self.samples_taken = self.clock.now(), 0
                self.regs[reg] = value
            self.pointer = (self.pointer + 1) & 0x7F

    def i2c_read(self, n: int) -> list[int]:
        self._update()
        out, read_status = [], False
        for _ in range(n):
            reg = self.pointer
            if reg not in self.READABLE:
                self.violations.append(f"read of reserved register 0x{reg:02X}")
            out.append(self.regs[reg])
            read_status |= reg == self.INT_STATUS
            self.pointer = (self.pointer + 1) & 0x7F
        if read_status or self.regs[self.INT_CFG] & 0x10:  # INT_ANYRD_2CLEAR
            self.regs[self.INT_STATUS] &= ~0x05 & 0xFF
        return out


# ----------------------------------------------------------------------------------------------------- HMC5843 ---


class HMC5843(I2CDevice):
    """HMC5843. Sources: registers.md §5 (kernel hmc5843), HMC5843 datasheet pp.15/18 (datasheetandpdf.com), and the
    sibling HMC5883 register/mode pages for behaviour the HMC5843 pages found do not show.

    Data are big-endian s16, order X, Y, Z, range -2048..2047; overflow reads -4096 [D p.15]. Once any data register is
    read no new data is written until all six are read; RDY is not cleared by reading, only when new data are written
    [D p.15 "RDY ... cannot be cleared until new data is placed"]. LOCK (b1) while some but not all six are read.
    `power_up_mode`: [U] MODE reset value (0x02 idle by default; 0x01 single as on HMC5883; 0x03 sleep).
    `first_sample_periods`: continuous mode delivers its first set after this many periods (HMC5883: 2/f_DO).
    `pointer_08_to_03`: [U] HMC5883 pointer rule (after 0x08 the pointer goes back to 0x03) instead of a plain increment.
    """

    CRA, CRB, MODE, DATA, STATUS = 0x00, 0x01, 0x02, 0x03, 0x09
    GAIN_LSB_PER_GA = (1620, 1300, 970, 780, 530, 460, 390, 280)
    RATE_HZ = (0.5, 1, 2, 5, 10, 20, 50, None)
    SINGLE_CONVERSION_S = 0.010  # [U] not given on the pages found

    def __init__(self, clock: ManualClock, ident: bytes = b"H43", field_ga=(0.2, -0.1, 0.4), power_up_mode: int = 0x02,
                 first_sample_periods: float = 2.0, pointer_08_to_03: bool = False) -> None:
        super().__init__(clock)
        self.regs = [0] * 13
        self.regs[self.CRA], self.regs[self.CRB], self.regs[self.MODE] = 0x10, 0x20, power_up_mode
        self.regs[0x0A:0x0D] = list(ident)
        self.field_ga = np.asarray(field_ga, float)
        self.first_sample_periods = first_sample_periods
        self.pointer_08_to_03 = pointer_08_to_03
        self.read_mask = 0  # which of the six data registers were read since the last data write
        self.pending = False
        self.measured_gain = self.regs[self.CRB] >> 5
        self._mode_changed()

    def counts_for(self, field_ga, gain_code: int | None = None) -> list[int]:
        g = self.GAIN_LSB_PER_GA[self.regs[self.CRB] >> 5 if gain_code is None else gain_code]
        out = []
        for f in field_ga:
            c = round(f * g)
            out.append(-4096 if not -2048 <= c <= 2047 else c)
        return out

    def _mode_changed(self) -> None:
        self.mode_since = self.clock.now()
        self.samples_taken = 0

    def _place(self, conversions: int = 1) -> None:
        """Write the newest of `conversions` measurements, unless a partial read holds the registers (then it is
        lost, as on the chip). The first conversion after a gain change still uses the old gain [U, HMC5883L p.13]."""
        if conversions > 1:
            self.measured_gain = self.regs[self.CRB] >> 5
        gain, self.measured_gain = self.measured_gain, self.regs[self.CRB] >> 5
        if self.read_mask:
            return
        values = self.counts_for(self.field_ga, gain)
        for i, v in enumerate(values):
            self.regs[self.DATA + 2 * i:self.DATA + 2 * i + 2] = _s16_bytes_be(v)
        self.regs[self.STATUS] |= 0x01

    def _update(self) -> None:
        md = self.regs[self.MODE] & 0x03
        now = self.clock.now()
        if md == 0:
            rate = self.RATE_HZ[(self.regs[self.CRA] >> 2) & 7] or 10.0
            first = self.mode_since + self.first_sample_periods / rate
            if now >= first:
                n = int((now - first) * rate) + 1
                if n > self.samples_taken:
                    self._place(n - self.samples_taken)
                    self.samples_taken = n
        elif md == 1 and now >= self.mode_since + self.SINGLE_CONVERSION_S:
            self._place()
            self.regs[self.MODE] = (self.regs[self.MODE] & ~0x03) | 0x03  # back to sleep

    def i2c_write(self, data: Sequence[int]) -> None:
        if not data:
            return
        self._update()
        self.pointer = data[0]
        for value in data[1:]:
            reg = self.pointer
            if reg > 2:
                self.violations.append(f"write 0x{value:02X} to read-only/invalid register 0x{reg:02X}")
            elif value & (0xE0, 0x1F, 0xFC)[reg]:
                self.violations.append(f"register 0x{reg:02X} <- 0x{value:02X} sets bits that must be cleared")
                self.regs[reg] = value
            else:
                self.regs[reg] = value
                if reg in (self.CRA, self.MODE):
                    self.read_mask = 0  # LOCK is released by a mode or measurement-configuration change
                if reg == self.MODE or (reg in (self.CRA, self.CRB) and (self.regs[self.MODE] & 3) == 0):
                    self._mode_changed()
            self.pointer = self._next(reg)

    def _next(self, reg: int) -> int:
        if self.pointer_08_to_03 and reg == 0x08:
            return 0x03
        return 0 if reg >= 12 else reg + 1

    def i2c_read(self, n: int) -> list[int]:
        self._update()
        out = []
        for _ in range(n):
            reg = self.pointer
            if reg > 12:
                out.append(0)
            elif reg == self.STATUS:
                lock = 0x02 if self.read_mask not in (0, 0x3F) else 0
                out.append((self.regs[reg] & 0x01) | lock)
            else:
                out.append(self.regs[reg])
            if self.DATA <= reg < self.DATA + 6:
                self.read_mask |= 1 << (reg - self.DATA)
                if self.read_mask == 0x3F:
                    self.read_mask = 0
            self.pointer = self._next(reg)
        return out


# ----------------------------------------------------------------------------------------------------------- SPI ---


class SpiPort:
    """spidev.SpiDev look-alike: `xfer2(list)` is one chip-select assertion; traffic costs wire time."""

    def __init__(self, clock: ManualClock, device=None, mode: int = 0, max_speed_hz: int = 500_000) -> None:
        self.clock = clock
        self.device = device
        self.mode = mode
        self.max_speed_hz = max_speed_hz
        self.bits_per_word = 8
        self.frames: list[tuple[list[int], list[int]]] = []

    def xfer2(self, data, /) -> list[int]:
        tx = [int(b) & 0xFF for b in data]
        self.clock.advance(8 * len(tx) / max(self.max_speed_hz, 1) + 1e-6)
        rx = [0x00] * len(tx) if self.device is None else self.device.transfer(tx, self)
        self.frames.append((tx, rx))
        return list(rx)

    xfer = xfer2

    def open(self, bus: int, dev: int) -> None:
        pass

    def close(self) -> None:
        pass


# ---------------------------------------------------------------------------------------------------- ADXRS453 ---


@dataclass
class ADXRS453:
    """ADXRS453 32-bit SPI frames. Sources: registers.md §4 (kernel adxrs450.c, no-OS, avarix), ADXRS450 datasheet
    Rev. C p.16 (fault bits are latched until reported).

    Full duplex with one frame of latency: the word clocked out in frame N answers command N-1, assembled with the
    chip's state at frame N. The first frame after power-on answers 0x00000001. A command with even parity gets an
    R/W error response with SE set. CHK (bit 1 of a sensor-data request) forces all fault bits and ST = 10 while it is
    asserted and for `chk_hold_s` after it is released ([U]; the datasheet start-up waits 50 ms between steps).
    80 LSB/(deg/s); TEM bits 15:6 = 5 LSB/degC, 0 at 45 degC.
    """

    clock: ManualClock
    rate_dps: float = 0.0
    temp_c: float = 25.0
    pid: int = 0x5202
    serial: int = 0x1234ABCD
    powered_at: float = 0.0
    chk_hold_s: float = 0.075
    forced_faults: int = 0  # fault-bit mask (b7 PLL .. b1 CHK) as seen in sensor responses
    corrupt_parity: bool = False
    require_mode: tuple[int, ...] = (0,)
    max_hz: float = 8.08e6
    last_command: int | None = None
    chk_asserted: bool = False
    chk_released_at: float = -1.0
    spi_error_pending: bool = False
    violations: list[str] = field(default_factory=list)
    dnc: int = 0

    FAULT_BITS = 0xFE

    def _checking(self) -> bool:
        return self.chk_asserted or self.clock.now() < self.chk_released_at + self.chk_hold_s

    def _register(self, addr: int) -> int | None:
        t10 = _clip((self.temp_c - 45.0) * 5.0, -512, 511)
        faults = self.FAULT_BITS if self._checking() else self.forced_faults
        table = {0x00: _clip(self.rate_dps * 80.0, -32768, 32767) & 0xFFFF, 0x02: (t10 & 0x3FF) << 6,
                 0x04: 0x0100, 0x06: 0x0200, 0x08: 0x0000, 0x0A: faults & 0x0FFE, 0x0C: self.pid,
                 0x0E: self.serial >> 16, 0x10: self.serial & 0xFFFF, 0x12: self.dnc}
        return table.get(addr & 0x1FE)

    @staticmethod
    def _finish(word: int) -> int:
        """Set P0 (bits 31:16 odd) then P1 (whole word odd)."""
        word &= ~((1 << 28) | 1) & 0xFFFFFFFF
        word |= _odd_parity_bit(word >> 16) << 28
        return word | _odd_parity_bit(word)

    def _response_to(self, cmd: int) -> int:
        if self.spi_error_pending:
            self.spi_error_pending = False
            return self._finish((0b11 << 26) | (1 << 18))
        kind = cmd >> 29
        if kind == 0b001:
            checking = self._checking()
            faults = self.FAULT_BITS if checking else self.forced_faults
            st = 0b10 if checking else (0b00 if faults & 0x80 else 0b01)
            rate = _clip(self.rate_dps * 80.0, -32768, 32767) & 0xFFFF
            sq = (cmd >> 26) & 0x7
            return self._finish((sq << 29) | (st << 26) | (rate << 10) | (faults & 0xFE))
        addr = (cmd >> 17) & 0x1FF
        value = self._register(addr)
        if kind == 0b100 and value is not None:
            return self._finish((0b010 << 29) | (0b11 << 26) | (value << 5))
        if kind == 0b010 and addr in (0x12, 0x13):
            return self._finish((0b001 << 29) | (0b11 << 26) | (self.dnc << 5))
        return self._finish((0b11 << 26) | (1 << 17))  # request error: bad address or command

    def transfer(self, tx: list[int], port: SpiPort) -> list[int]:
        if port.mode not in self.require_mode or port.max_speed_hz > self.max_hz:
            self.violations.append(f"SPI mode {port.mode} / {port.max_speed_hz} Hz outside datasheet limits")
            return [0xFF] * len(tx)
        if len(tx) != 4:
            self.violations.append(f"frame of {len(tx)} bytes; the ADXRS453 frame is 32 bits per chip select")
            return [0x00] * len(tx)
        now = self.clock.now()
        if now < self.powered_at + 0.1:
            self.violations.append(f"frame {now - self.powered_at:.4f} s after power-on (< 100 ms)")
        cmd = int.from_bytes(bytes(tx), "big")
        if self.last_command is None:
            out = 0x00000001
        else:
            out = self._response_to(self.last_command)
            if self.corrupt_parity:
                out ^= 1 << 12
        if bin(cmd).count("1") % 2 == 0:
            self.spi_error_pending = True
        elif cmd >> 29 == 0b001:
            chk = bool(cmd & 0x2)
            if self.chk_asserted and not chk:
                self.chk_released_at = now
            self.chk_asserted = chk
        elif cmd >> 29 == 0b010 and ((cmd >> 17) & 0x1FE) == 0x12:
            self.dnc = (cmd >> 1) & 0x3FF
        self.last_command = cmd
        return list(out.to_bytes(4, "big"))


# ----------------------------------------------------------------------------------------------------- MCP3208 ---


class MCP3208:
    """MCP3208 bit-level: sources registers.md §8 (kernel mcp320x, DS21298E p.1).

    The first 1 clocked in is the start bit, then SGL/DIFF, D2, D1, D0; the next clock samples, then DOUT drives a null
    0 and B11..B0 MSB first, then (if clocks continue) B1..B11 LSB first, then zeros. Before the null bit DOUT is high-Z
    (read as `hiz_level`). code = floor(4096 * (V_in+ - V_in-) / V_REF), 0..4095.
    """

    def __init__(self, volts: Callable[[int], float], vref: float = 3.3, hiz_level: int = 1,
                 modes: tuple[int, ...] = (0, 3), max_hz: float = 2.0e6) -> None:
        self.volts, self.vref, self.hiz_level = volts, vref, hiz_level
        self.modes, self.max_hz = modes, max_hz
        self.conversions: list[tuple[int, bool, int]] = []
        self.violations: list[str] = []

    def code(self, channel: int, single: bool = True) -> int:
        if single:
            v = self.volts(channel)
        else:
            v = self.volts(channel) - self.volts(channel ^ 1)
        return max(0, min(4095, math.floor(4096.0 * v / self.vref)))

    def transfer(self, tx: list[int], port: SpiPort) -> list[int]:
        if port.mode not in self.modes or port.max_speed_hz > self.max_hz:
            self.violations.append(f"SPI mode {port.mode} / {port.max_speed_hz} Hz outside datasheet limits")
        bits_in = [(b >> (7 - i)) & 1 for b in tx for i in range(8)]
        bits_out = [self.hiz_level] * len(bits_in)
        try:
            start = bits_in.index(1)
        except ValueError:
            return [0xFF if self.hiz_level else 0x00] * len(tx)
        if start + 5 < len(bits_in):
            single = bool(bits_in[start + 1])
            ch = bits_in[start + 2] << 2 | bits_in[start + 3] << 1 | bits_in[start + 4]
            value = self.code(ch, single)
            self.conversions.append((ch, single, value))
            msb_first = [(value >> (11 - k)) & 1 for k in range(12)]
            stream = [0] + msb_first + msb_first[-2::-1]
            for k in range(start + 6, len(bits_in)):
                j = k - (start + 6)
                bits_out[k] = stream[j] if j < len(stream) else 0
        out = []
        for i in range(0, len(bits_out), 8):
            out.append(sum(bit << (7 - j) for j, bit in enumerate(bits_out[i:i + 8])))
        return out


# ------------------------------------------------------------------------------------------- analog front ends ---


@dataclass
class ADXL330Model:
    """ADXL330 ratiometric output: V = VS * (0.5 + 0.1 * a_g) (300 mV/g at 3 V) [registers.md §2; ADXL335 p.12]."""

    supply_v: float = 3.3
    accel_g: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def volts(self, axis: int) -> float:
        return self.supply_v * (0.5 + 0.1 * self.accel_g[axis])


@dataclass
class HMC1053Model:
    """HMC1053 bridges behind instrumentation amplifiers referenced to mid-supply [registers.md §6]:
    V = V_mid + G * (polarity * S * V_bridge * H + V_offset); S = 1 mV/V/G; set/reset flips `polarity`."""

    bridge_v: float = 3.3
    amp_gain: float = 100.0
    mid_v: float = 1.65
    field_ga: tuple[float, float, float] = (0.2, -0.1, 0.4)
    offset_v: tuple[float, float, float] = (0.4e-3, -0.3e-3, 0.2e-3)
    polarity: int = 1

    def volts(self, axis: int) -> float:
        bridge = self.polarity * 1e-3 * self.bridge_v * self.field_ga[axis] + self.offset_v[axis]
        return self.mid_v + self.amp_gain * bridge

    def pulse(self, set_pulse: bool) -> None:
        self.polarity = 1 if set_pulse else -1
