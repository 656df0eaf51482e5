"""TCA9548A 8-channel I2C switch, and the view of one of its channels that chip drivers take as their bus.

Several boards whose chips share an I2C address sit on the channels of one switch. The switch has one 8-bit
control register and no register pointer: a write of one byte after the address sets it, a one-byte read returns
it (TI SCPS207 8.5.3/8.5.4; Linux `i2c-mux-pca954x.c` writes it with one single-byte message and reads it with
`i2c_smbus_read_byte`). Bit n enables channel n, several may be on at once, 0 (the power-on and reset value)
disconnects every channel. Addresses 0x70..0x77 by A2..A0. A selection takes effect at the STOP that ends the
write, so it cannot share a combined (repeated-start) transaction with the transfer it is for.

The selection is cached as the kernel caches its `last_chan`: a transfer on the channel already selected writes
nothing, and a failed write forgets the cache so that the next select writes again. The optional RESET line
(active low) returns the register to 0 without the bus: `reset()` pulses it when a line is given.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from drivers.errors import SensorFault, wrap_os_error

ADDRESSES = range(0x70, 0x78)
CHANNELS = 8
ALL_OFF = 0x00
RESET_PULSE_S = 1e-6          # the kernel's pulse; the datasheet's t_W(L) minimum is shorter


class TCA9548A:
    """The switch at `address` on `bus` (an smbus2.SMBus-like object).

    `reset_line(level)` drives the RESET pin (0 = asserted) when the board wires it; `selects` counts the control
    writes `select` made (what the bus budget charges per change of channel).
    """

    chip = "TCA9548A"

    def __init__(self, bus: Any, address: int = 0x70, *, reset_line: Callable[[int], None] | None = None,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        if isinstance(address, bool) or not isinstance(address, int) or address not in ADDRESSES:
            raise ValueError(f"{self.chip}: I2C address {address!r} is not one of 0x70..0x77 (A2..A0)")
        self.bus, self.address = bus, address
        self.location = f"{self.chip} I2C switch at address 0x{address:02X}"
        self.reset_line, self.sleep = reset_line, sleep
        self.selects = 0
        self._cached: int | None = None          # control register as last written; None = unknown

    def _write(self, value: int, action: str) -> None:
        try:
            self.bus.write_byte(self.address, value)
        except OSError as exc:
            self._cached = None
            raise wrap_os_error(exc, f"{self.location}, control register", action) from exc
        self._cached = value

    def select(self, channel: int) -> None:
        """Connect channel `channel` (0..7) alone; writes only when the cached selection differs."""
        if isinstance(channel, bool) or not isinstance(channel, int) or not 0 <= channel < CHANNELS:
            raise ValueError(f"{self.location}: channel {channel!r} is not 0..{CHANNELS - 1}")
        value = 1 << channel
        if self._cached != value:
            self._write(value, f"select channel {channel} (write 0x{value:02X})")
            self.selects += 1

    def deselect(self) -> None:
        """Disconnect every channel (write 0), as the kernel does at probe and resume."""
        self._write(ALL_OFF, "deselect all channels (write 0x00)")

    def selected(self) -> int | None:
        """The channel the control register (read back from the chip) connects, None when none is; a register with
        several channels on is a SensorFault naming them (this driver never writes one)."""
        try:
            value = self.bus.read_byte(self.address)
        except OSError as exc:
            raise wrap_os_error(exc, f"{self.location}, control register", "read") from exc
        if value == ALL_OFF:
            return None
        on = [n for n in range(CHANNELS) if value >> n & 1]
        if len(on) > 1:
            raise SensorFault(f"{self.location}: control register 0x{value:02X} connects channels {on} at once")
        return on[0]

    def reset(self) -> None:
        """Pulse RESET low (the register returns to 0, every channel off); without a wired line, write 0."""
        if self.reset_line is None:
            self.deselect()
            return
        self.reset_line(0)
        self.sleep(RESET_PULSE_S)
        self.reset_line(1)
        self._cached = ALL_OFF


class MuxChannel:
    """An smbus2.SMBus-like view of one channel: every transfer selects the channel first, then goes to `bus`.

    A chip driver handed a MuxChannel instead of the bus works unchanged; its errors still name its own chip and
    address, and a switch that does not answer raises a DeviceAbsent naming the switch.
    """

    def __init__(self, bus: Any, switch: TCA9548A, channel: int) -> None:
        if isinstance(channel, bool) or not isinstance(channel, int) or not 0 <= channel < CHANNELS:
            raise ValueError(f"{switch.location}: channel {channel!r} is not 0..{CHANNELS - 1}")
        self.bus, self.switch, self.channel = bus, switch, channel
        self.label = f"channel {channel} of the {switch.location}"

    def _on(self) -> Any:
        self.switch.select(self.channel)
        return self.bus

    def write_quick(self, i2c_addr: int, force: bool | None = None) -> None:
        return self._on().write_quick(i2c_addr, force)

    def read_byte(self, i2c_addr: int, force: bool | None = None) -> int:
        return self._on().read_byte(i2c_addr, force)

    def write_byte(self, i2c_addr: int, value: int, force: bool | None = None) -> None:
        return self._on().write_byte(i2c_addr, value, force)

    def read_byte_data(self, i2c_addr: int, register: int, force: bool | None = None) -> int:
        return self._on().read_byte_data(i2c_addr, register, force)

    def write_byte_data(self, i2c_addr: int, register: int, value: int, force: bool | None = None) -> None:
        return self._on().write_byte_data(i2c_addr, register, value, force)

    def read_word_data(self, i2c_addr: int, register: int, force: bool | None = None) -> int:
        return self._on().read_word_data(i2c_addr, register, force)

    def write_word_data(self, i2c_addr: int, register: int, value: int, force: bool | None = None) -> None:
        return self._on().write_word_data(i2c_addr, register, value, force)

    def process_call(self, i2c_addr: int, register: int, value: int, force: bool | None = None) -> int:
        return self._on().process_call(i2c_addr, register, value, force)

    def read_block_data(self, i2c_addr: int, register: int, force: bool | None = None) -> list[int]:
        return self._on().read_block_data(i2c_addr, register, force)

    def write_block_data(self, i2c_addr: int, register: int, data: list[int], force: bool | None = None) -> None:
        return self._on().write_block_data(i2c_addr, register, data, force)

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int,
                            force: bool | None = None) -> list[int]:
        return self._on().read_i2c_block_data(i2c_addr, register, length, force)

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: list[int],
                             force: bool | None = None) -> None:
        return self._on().write_i2c_block_data(i2c_addr, register, data, force)

    def i2c_rdwr(self, *i2c_msgs: Any) -> None:
        return self._on().i2c_rdwr(*i2c_msgs)

    def close(self) -> None:
        """The channel does not own the bus: closing a view leaves the bus and the switch alone."""
