"""ADXRS453 single-axis gyroscope: 32-bit SPI frames (mode 0) with a one-frame response latency.

Frame layout, start-up and registers follow Linux `adxrs450.c`, ADI no-OS `adxrs453.c` and robotter/avarix
`adxrs.c` (registers.md section 4). The response clocked out during frame N answers command N-1, so the driver
remembers what it sent last and checks each response against that command before using it.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any, Callable, Sequence

from drivers._regs import spi_label
from drivers.contract import Part, Placement, Sensor, Thermometer, Wiring, chip_driver
from drivers.errors import DeviceAbsent, ProtocolError, SensorFault, WrongIdentity, wrap_os_error
from drivers.regmap import RegisterMap, Reg, ROBit


class ADXRS453Registers(RegisterMap):
    """ADXRS453 16-bit registers reached through read/write command frames (registers.md section 4)."""

    chip = "ADXRS453"
    RATE, TEM = Reg(0x00, access="r", width=2), Reg(0x02, access="r", width=2)
    LOCST, HICST = Reg(0x04, access="r", width=2), Reg(0x06, access="r", width=2)
    QUAD, FAULT = Reg(0x08, access="r", width=2), Reg(0x0A, access="r", width=2)
    PID, SN_HIGH = Reg(0x0C, access="r", width=2), Reg(0x0E, access="r", width=2)
    SN_LOW, DNC = Reg(0x10, access="r", width=2), Reg(0x12, width=2)

    FAIL, AMP, OV, UV = ROBit(FAULT, 11), ROBit(FAULT, 10), ROBit(FAULT, 9), ROBit(FAULT, 8)
    PLL, Q, NVM, POR = ROBit(FAULT, 7), ROBit(FAULT, 6), ROBit(FAULT, 5), ROBit(FAULT, 4)
    PWR, CST, CHK = ROBit(FAULT, 3), ROBit(FAULT, 2), ROBit(FAULT, 1)


R = ADXRS453Registers
NAMES = R.NAMES
RATE, TEM, FAULT, PID, SN_HIGH, SN_LOW, DNC = (int(r) for r in (R.RATE, R.TEM, R.FAULT, R.PID, R.SN_HIGH,
                                                                R.SN_LOW, R.DNC))
SENSOR_DATA, READ, WRITE = 0x20000000, 0x80000000, 0x40000000
CHK = 0x00000002

# Fault bits 7:1 of a sensor-data response frame (a frame layout, not a register)
FAULT_FLAGS = ((0x80, "PLL"), (0x40, "Q"), (0x20, "NVM"), (0x10, "POR"), (0x08, "PWR"), (0x04, "CST"),
               (0x02, "CHK"))
ERROR_FLAGS = ((1 << 18, "SE (SPI error)"), (1 << 17, "RE (request error)"), (1 << 16, "DU (data unavailable)"))
ST_NAMES = {0: "00 (invalid data)", 1: "01 (valid data)", 2: "10 (self-test data)", 3: "11 (R/W response)"}

# Sensor-data response, valid, no faults: bits 31:29 (SQ echo) = 000, ST (27:26) = 01, fault bits 7:1 = 0.
DATA_MASK, DATA_OK = 0xEC0000FE, 0x04000000
POWER_ON_RESPONSE = 0x00000001
PID_HIGH = 0x52
LSB_PER_DPS = 80.0
RANGE_DPS = 300.0
POWER_UP_WAIT_S, STEP_WAIT_S = 0.1, 0.05

SPI_MODE = 0
SPI_MAX_HZ = 8_080_000


def with_parity(word: int) -> int:
    """Set P (bit 0) so the whole 32-bit command has odd parity (kernel hweight32 rule)."""
    word &= ~1
    return word if word.bit_count() & 1 else word | 1


def read_command(reg: int) -> int:
    return with_parity(READ | (reg << 17))


def write_command(reg: int, value: int) -> int:
    return with_parity(WRITE | (reg << 17) | ((value & 0xFFFF) << 1))


def parity_ok(word: int) -> bool:
    """P0 makes bits 31:16 odd, P1 makes the whole word odd (avarix adxrs_check_response_parity)."""
    return bool(word.bit_count() & 1) and bool((word >> 16).bit_count() & 1)


def flag_names(bits: int, table: Sequence[tuple[int, str]]) -> str:
    return ", ".join(name for mask, name in table if bits & mask) or "none"


def _s16(value: int) -> int:
    return value - 0x10000 if value & 0x8000 else value


@chip_driver
class ADXRS453(Part, Thermometer):
    """One ADXRS453 on a spidev-like `spi` (xfer2). `cs` labels the chip select in messages."""

    chip = "ADXRS453"
    BUSES = ("spi",)

    def __init__(self, spi: Any, *, cs: Any = None, sleep: Callable[[float], None] = time.sleep) -> None:
        self.spi, self.sleep = spi, sleep
        self.location = f"{self.chip} on SPI {spi_label(spi, cs)}"
        self._pending: int | None = None  # command whose response arrives in the next frame
        self.part_id: int | None = None
        self.started = False

    # -- framing -------------------------------------------------------------------------------------------

    def _frame(self, command: int) -> int:
        try:
            rx = self.spi.xfer2([command >> 24, (command >> 16) & 0xFF, (command >> 8) & 0xFF, command & 0xFF])
        except OSError as exc:
            raise wrap_os_error(exc, self.location, f"frame 0x{command:08X}") from exc
        return (rx[0] << 24) | (rx[1] << 16) | (rx[2] << 8) | rx[3]

    def _describe(self, command: int | None) -> str:
        if command is None:
            return "unknown command"
        kind = command >> 29
        if kind == 0b001:
            return f"sensor-data request 0x{command:08X}"
        reg = (command >> 17) & 0x1FF
        verb = "read" if kind == 0b100 else "write"
        return f"{verb} of register 0x{reg:02X} {NAMES.get(reg, '?')} (command 0x{command:08X})"

    def _bad(self, word: int, command: int | None, problem: str, cls: type = ProtocolError) -> Exception:
        return cls(f"{self.location}: frame 0x{word:08X} answering {self._describe(command)}: {problem}")

    def _check_parity(self, word: int, command: int | None) -> None:
        if not word.bit_count() & 1:
            raise self._bad(word, command, "P1 parity error (whole word not odd)")
        if not (word >> 16).bit_count() & 1:
            raise self._bad(word, command, "P0 parity error (bits 31:16 not odd)")

    def _check_error_response(self, word: int, command: int | None) -> None:
        if word >> 29 == 0 and (word >> 26) & 3 == 3:
            raise self._bad(word, command, f"R/W error response: {flag_names(word, ERROR_FLAGS)}")

    def _rate_from(self, word: int, command: int | None) -> int:
        """Decode a sensor-data response; anything but valid, fault-free data raises."""
        if (word & DATA_MASK) == DATA_OK and parity_ok(word):
            return _s16((word >> 10) & 0xFFFF)
        self._check_parity(word, command)
        self._check_error_response(word, command)
        if word >> 29:
            raise self._bad(word, command, f"unexpected response type {word >> 29:03b} (SQ should echo 000)")
        st = (word >> 26) & 3
        if st != 1:
            raise self._bad(word, command, f"status ST = {ST_NAMES[st]}", SensorFault)
        raise self._bad(word, command, f"fault bits set: {flag_names(word, FAULT_FLAGS)}", SensorFault)

    def _register_from(self, word: int, command: int) -> int:
        """Decode a read response (type 010, ST = 11): data in bits 20:5."""
        self._check_parity(word, command)
        self._check_error_response(word, command)
        if word >> 29 != 0b010 or (word >> 26) & 3 != 3:
            raise self._bad(word, command, f"expected a read response (type 010, ST 11), got type "
                                           f"{word >> 29:03b}, ST {(word >> 26) & 3:02b}")
        return (word >> 5) & 0xFFFF

    def _exchange(self, command: int) -> int | None:
        """Send `command`; check and decode the response to the previous one; return its payload."""
        previous = self._pending
        word = self._frame(command)
        self._pending = command
        if previous is None:
            self._check_parity(word, previous)
            return None
        kind = previous >> 29
        if kind == 0b001:
            return self._rate_from(word, previous)
        if kind == 0b100:
            return self._register_from(word, previous)
        self._check_parity(word, previous)
        self._check_error_response(word, previous)
        if word >> 29 != 0b001 or (word >> 26) & 3 != 3:
            raise self._bad(word, previous, "expected a write response (type 001, ST 11)")
        return (word >> 5) & 0xFFFF

    # -- start-up ------------------------------------------------------------------------------------------

    def start(self) -> None:
        """Recommended start-up: CHK request, two ST=10 all-fault responses, then ST=01 fault-free, PID, FAULT."""
        self.sleep(POWER_UP_WAIT_S)
        first = self._frame(SENSOR_DATA | CHK | 1)
        if first in (0x00000000, 0xFFFFFFFF):
            raise DeviceAbsent(f"{self.location}: frame 0x{first:08X} answering the CHK request "
                               f"(MISO stuck at a rail; chip absent or unpowered?)")
        if first != POWER_ON_RESPONSE:  # restarted without power cycle: any well-formed frame will do
            self._check_parity(first, None)
        self.sleep(STEP_WAIT_S)
        self._check_parity(self._frame(SENSOR_DATA), SENSOR_DATA | CHK | 1)
        self.sleep(STEP_WAIT_S)
        for _ in range(2):
            word = self._frame(SENSOR_DATA)
            self._check_parity(word, SENSOR_DATA)
            if (word >> 26) & 3 != 2 or (word & 0xFE) != 0xFE:
                raise self._bad(word, SENSOR_DATA, "CHK self-check failed: expected ST = 10 with every fault "
                                                   "bit set (low byte 0xFE/0xFF)", SensorFault)
        self._pending = SENSOR_DATA
        self.sleep(STEP_WAIT_S)
        self._exchange(read_command(PID))                 # answer: sensor data, must be ST = 01, no faults
        part_id = self._exchange(read_command(FAULT))
        if part_id >> 8 != PID_HIGH:
            raise WrongIdentity(f"{self.location}, register 0x{PID:02X} PID: read 0x{part_id:04X}, expected "
                                f"0x{PID_HIGH:02X}xx")
        fault = self._exchange(SENSOR_DATA)
        if fault & 0x0FFF:
            raise SensorFault(f"{self.location}, register 0x{FAULT:02X} FAULT: 0x{fault:04X} "
                              f"({', '.join(R.flags(R.FAULT, fault)) or 'none'})")
        self.part_id = part_id
        self.started = True

    # -- data ----------------------------------------------------------------------------------------------

    def read_raw(self, fresh: bool = False) -> int:
        """Rate in counts (80 LSB per deg/s).

        The answer to a sensor-data request comes in the next frame, so a plain read returns the rate
        latched at the previous call. `fresh=True` spends one extra frame to latch the rate now (ADI's
        read-twice pattern), so the sample belongs to this call's time stamp.
        """
        if fresh or self._pending != SENSOR_DATA:
            self._exchange(SENSOR_DATA)
        try:
            rx = self.spi.xfer2([0x20, 0x00, 0x00, 0x00])
        except OSError as exc:
            raise wrap_os_error(exc, self.location, "frame 0x20000000") from exc
        word = (rx[0] << 24) | (rx[1] << 16) | (rx[2] << 8) | rx[3]
        if (word & DATA_MASK) == DATA_OK and word.bit_count() & 1 and (word >> 16).bit_count() & 1:
            rate = (word >> 10) & 0xFFFF
            return rate - 0x10000 if rate & 0x8000 else rate
        return self._rate_from(word, SENSOR_DATA)

    def read_register(self, reg: int) -> int:
        """16-bit register read: the read command, then a sensor-data frame that carries the answer."""
        if reg not in NAMES:
            raise ValueError(f"{self.chip}: unknown register 0x{reg:02X}; allowed: "
                             + ", ".join(f"0x{r:02X} {n}" for r, n in NAMES.items()))
        self._exchange(read_command(reg))
        return self._exchange(SENSOR_DATA)

    def write_register(self, reg: int, value: int) -> None:
        """16-bit register write (only DNC is writable); the write response is checked on the next frame."""
        declared = R.REGS.get(NAMES.get(reg, ""))
        if declared is None or declared.access != "rw":
            raise ValueError(f"{self.chip}: register 0x{reg:02X} is not writable; allowed: 0x{DNC:02X} DNC")
        self._exchange(write_command(reg, value))
        self._exchange(SENSOR_DATA)

    def read_temperature(self) -> float:
        """TEM bits 15:6 as 10-bit two's complement: T = 45 + t/5 degC (kernel)."""
        t10 = _s16(self.read_register(TEM)) >> 6
        return 45.0 + t10 / 5.0

    def read_fault(self) -> int:
        """FAULT register (FAIL, AMP, OV, UV, PLL, Q, NVM, POR, PWR, CST, CHK in bits 11:1)."""
        return self.read_register(FAULT)

    def serial_number(self) -> int:
        return (self.read_register(SN_HIGH) << 16) | self.read_register(SN_LOW)

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "ADXRS453":
        return cls(wiring.bus_for(placement, SPI_MODE, SPI_MAX_HZ), cs=placement.cs, sleep=wiring.sleep)

    def settings(self) -> dict:
        """Snapshot for session metadata; `scale` is rad/s per count. Range and rate are fixed in the chip."""
        return {
            "chip": self.chip, "interface": "spi", "location": self.location,
            "range": RANGE_DPS, "range_unit": "deg/s",
            "rate_hz": None,
            "part_id": self.part_id,
            "scale": math.radians(1.0 / LSB_PER_DPS), "scale_unit": "rad/s per LSB",
        }


@chip_driver
class GyroTriad(Sensor, Thermometer):
    """Three ADXRS453 mounted on orthogonal axes, read as one (x, y, z) triad."""

    chip = "ADXRS453 triad"
    BUSES, SENSES = ("spi",), ("gyro",)

    def __init__(self, gyros: Sequence[ADXRS453]) -> None:
        if len(gyros) != 3:
            raise ValueError(f"{self.chip}: need exactly 3 ADXRS453 (x, y, z), got {len(gyros)}")
        self.gyros = tuple(gyros)

    def start(self) -> None:
        for gyro in self.gyros:
            gyro.start()

    def read_raw(self) -> tuple[int, int, int]:
        """The three rates latched now (fresh reads), so the triad's sample matches its time stamp."""
        x, y, z = self.gyros
        return x.read_raw(True), y.read_raw(True), z.read_raw(True)

    def read_temperatures(self) -> tuple[float, float, float]:
        x, y, z = self.gyros
        return x.read_temperature(), y.read_temperature(), z.read_temperature()

    def read_temperature(self) -> float:
        """Mean of the three die temperatures (one figure for the session's temperature column)."""
        return sum(self.read_temperatures()) / 3.0

    def settings(self) -> dict:
        first = self.gyros[0].settings()
        return {**first, "chip": self.chip, "location": [g.location for g in self.gyros],
                "part_id": [g.part_id for g in self.gyros]}

    @classmethod
    def attach(cls, placement: Placement, wiring: Wiring) -> "GyroTriad":
        """Three ADXRS453 on the chip selects `placement.cs` = (x, y, z)."""
        selects = placement.cs if isinstance(placement.cs, (tuple, list)) else ()
        if len(selects) != 3:
            raise ValueError(f"{placement.name} ({cls.chip}): needs 3 chip selects (x, y, z), got {placement.cs!r}")
        return cls([ADXRS453.attach(replace(placement, cs=int(cs)), wiring) for cs in selects])
