"""Register access over smbus2-like I2C or spidev-like SPI, with errors that name chip, bus and register.

Shared by the register-mapped drivers; the hot paths of each driver call the bus directly instead.
"""

from __future__ import annotations

from typing import Any, Mapping

from drivers.errors import DeviceAbsent, wrap_os_error


class I2cRegisters:
    """8-bit register file behind an I2C address (plain register addresses, auto-increment bursts)."""

    MAX_BLOCK = 32

    def __init__(self, bus: Any, address: int, chip: str, names: Mapping[int, str]) -> None:
        self.bus, self.address, self.chip, self.names = bus, address, chip, names
        self.location = f"{chip} at I2C address 0x{address:02X}"

    def where(self, reg: int) -> str:
        return f"{self.location}, register 0x{reg:02X} {self.names.get(reg, '?')}"

    def read(self, reg: int) -> int:
        try:
            return self.bus.read_byte_data(self.address, reg)
        except OSError as exc:
            raise wrap_os_error(exc, self.where(reg), "read") from exc

    def write(self, reg: int, value: int) -> None:
        try:
            self.bus.write_byte_data(self.address, reg, value)
        except OSError as exc:
            raise wrap_os_error(exc, self.where(reg), f"write 0x{value:02X}") from exc

    def read_block(self, reg: int, length: int) -> bytes:
        try:
            return bytes(self.bus.read_i2c_block_data(self.address, reg, length))
        except OSError as exc:
            raise wrap_os_error(exc, self.where(reg), f"{length}-byte burst read") from exc


class SpiRegisters:
    """ADXL345-family SPI register access: address byte bit 7 = read, bit 6 = multi-byte (auto-increment)."""

    READ = 0x80
    MULTI = 0x40
    ADDRESS_MASK = 0x3F

    def __init__(self, spi: Any, cs: str, chip: str, names: Mapping[int, str]) -> None:
        self.spi, self.chip, self.names = spi, chip, names
        self.location = f"{chip} on SPI {cs}"

    def where(self, reg: int) -> str:
        return f"{self.location}, register 0x{reg:02X} {self.names.get(reg, '?')}"

    def _xfer(self, frame: list, reg: int, action: str) -> list:
        try:
            return self.spi.xfer2(frame)
        except OSError as exc:
            raise wrap_os_error(exc, self.where(reg), action) from exc

    def read(self, reg: int) -> int:
        return self._xfer([self.READ | reg, 0x00], reg, "read")[1]

    def write(self, reg: int, value: int) -> None:
        self._xfer([reg & self.ADDRESS_MASK, value], reg, f"write 0x{value:02X}")

    def read_block(self, reg: int, length: int) -> bytes:
        rx = self._xfer([self.READ | self.MULTI | reg] + [0x00] * length, reg, f"{length}-byte burst read")
        return bytes(rx[1:])


class StSpiRegisters(SpiRegisters):
    """ST MEMS SPI register access: bit 7 = read, 7-bit address, bursts auto-increment by CTRL3_C.IF_INC."""

    MULTI = 0x00
    ADDRESS_MASK = 0x7F


def check_not_floating(value: int, where: str) -> None:
    """An SPI identity byte of 0x00 or 0xFF means MISO is stuck at a rail: no chip is driving it."""
    if value in (0x00, 0xFF):
        raise DeviceAbsent(f"{where}: read 0x{value:02X} (MISO stuck at a rail; chip absent or unpowered?)")


def spi_label(spi: Any, cs: Any) -> str:
    """Chip-select label for messages: the caller's label, else a 'label' attribute, else 'chip select ?'."""
    if cs is not None:
        return str(cs)
    return str(getattr(spi, "label", "chip select ?"))


def choose(value: Any, allowed: Mapping, what: str, chip: str, unit: str = "") -> Any:
    """Look `value` up in `allowed`; a miss raises ValueError listing every allowed value."""
    for key, code in allowed.items():
        if value == key:
            return code
    choices = ", ".join(f"{k:g}" if isinstance(k, float) else str(k) for k in allowed)
    raise ValueError(f"{chip}: unsupported {what} {value!r}{unit}; allowed: {choices}{unit}")
