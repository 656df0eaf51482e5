"""A chip's register map declared once, as a table of registers and field descriptors.

In the style of Adafruit_CircuitPython_Register (`RWBits(num_bits, register_address, lowest_bit)`): a field is
a class attribute of the chip's map, so reading `regs.measure` reads POWER_CTL and extracts bit 3, and writing
`regs.measure = 1` does a read-modify-write. Start-up sequences write whole registers instead
(`regs.put(DATA_FORMAT, full_res=1, range=3)`: one bus write, the other bits zero), so a driver never ORs masks
by hand and the bus sees exactly the writes the datasheet sequence lists.

The map only knows `read(address)`, `write(address, value)` and `read_block(address, n)` of the object it is
bound to (`drivers._regs.I2cRegisters` / `SpiRegisters`, or a chip's own frame protocol).
"""

from __future__ import annotations

from typing import Any, ClassVar


class Reg:
    """One register: address, access ("r", "rw", "w") and width in bytes; its name is the attribute's name."""

    def __init__(self, address: int, *, access: str = "rw", width: int = 1) -> None:
        self.address, self.access, self.width = address, access, width
        self.name = f"0x{address:02X}"

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __index__(self) -> int:
        return self.address

    def __repr__(self) -> str:
        return f"Reg(0x{self.address:02X} {self.name})"


class Bits:
    """A `bits`-wide field starting at bit `lowest` of register `reg`."""

    def __init__(self, bits: int, reg: Reg, lowest: int, *, readonly: bool = False) -> None:
        if not (bits >= 1 and 0 <= lowest and lowest + bits <= 8 * reg.width):
            raise ValueError(f"field of {bits} bits at bit {lowest} does not fit register {reg!r}")
        self.bits, self.reg, self.lowest, self.readonly = bits, reg, lowest, readonly
        self.address = reg.address
        self.top = (1 << bits) - 1
        self.mask = self.top << lowest
        self.name = "?"

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def get(self, value: int) -> int:
        """This field out of a register value already read."""
        return (value >> self.lowest) & self.top

    def place(self, value: int, chip: str = "") -> int:
        """`value` moved into position; a value that does not fit is a ValueError naming chip, register, field."""
        value = int(value)
        if not 0 <= value <= self.top:
            raise ValueError(f"{chip}: {self.reg.name}.{self.name} = {value} does not fit {self.bits} bit(s) "
                             f"(0..{self.top})")
        return value << self.lowest

    def __get__(self, regs: "RegisterMap | None", owner: type | None = None) -> Any:
        if regs is None:
            return self
        return (regs.io.read(self.address) >> self.lowest) & self.top     # regs.read, one call: data-ready polls

    def __set__(self, regs: "RegisterMap", value: int) -> None:
        if self.readonly:
            raise AttributeError(f"{regs.chip}: {self.reg.name}.{self.name} is read-only")
        old = regs.read(self.reg)
        regs.write(self.reg, (old & ~self.mask) | self.place(value, regs.chip))


def RWBits(bits: int, reg: Reg, lowest: int) -> Bits:
    return Bits(bits, reg, lowest)


def ROBits(bits: int, reg: Reg, lowest: int) -> Bits:
    return Bits(bits, reg, lowest, readonly=True)


def RWBit(reg: Reg, bit: int) -> Bits:
    return Bits(1, reg, bit)


def ROBit(reg: Reg, bit: int) -> Bits:
    return Bits(1, reg, bit, readonly=True)


class RegisterMap:
    """Base of a chip's register table; an instance binds the table to a register transport `io`."""

    chip: ClassVar[str] = "?"
    REGS: ClassVar[dict[str, Reg]]
    NAMES: ClassVar[dict[int, str]]
    FIELDS: ClassVar[dict[str, Bits]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        regs, fields = {}, {}
        for klass in reversed(cls.__mro__):
            for name, value in vars(klass).items():
                if isinstance(value, Reg):
                    regs[name] = value
                elif isinstance(value, Bits):
                    fields[name] = value
        cls.REGS, cls.FIELDS = regs, fields
        cls.NAMES = {reg.address: name for name, reg in regs.items()}

    def __init__(self, io: Any) -> None:
        self.io = io
        self.configured: dict[int, int] = {}     # register -> the value last written to it

    def read(self, reg: Reg | int) -> int:
        return self.io.read(int(reg))

    def write(self, reg: Reg | int, value: int) -> None:
        self.io.write(int(reg), value)
        self.configured[int(reg)] = value

    def lost(self) -> str | None:
        """The first register that no longer holds what was last written to it (the chip reset to its power-on
        values: a brown-out, ESD), said with its address and both values; None while the chip keeps them all."""
        for address, value in self.configured.items():
            now = self.read(address)
            if now != value:
                return f"{self.where(address)} reads 0x{now:02X}, configured 0x{value:02X}"
        return None

    def read_block(self, reg: Reg | int, length: int) -> bytes:
        return self.io.read_block(int(reg), length)

    def where(self, reg: Reg | int) -> str:
        return self.io.where(int(reg))

    @classmethod
    def compose(cls, reg: Reg, **fields: int) -> int:
        """The whole value of `reg` with the named fields set and every other bit zero."""
        value = 0
        for name, field_value in fields.items():
            field = cls.FIELDS.get(name)
            if field is None or field.reg is not reg:
                allowed = sorted(n for n, f in cls.FIELDS.items() if f.reg is reg)
                raise ValueError(f"{cls.chip}: {reg.name} has no field {name!r}; fields: {allowed}")
            value |= field.place(field_value, cls.chip)
        return value

    def put(self, reg: Reg, **fields: int) -> None:
        """Write `reg` whole, in one bus write, from its named fields (unnamed bits are written as 0)."""
        self.write(reg, self.compose(reg, **fields))

    @classmethod
    def flags(cls, reg: Reg, value: int) -> list[str]:
        """Names of the one-bit fields of `reg` that are set in `value`, highest bit first."""
        ones = sorted((f for f in cls.FIELDS.values() if f.reg is reg and f.bits == 1), key=lambda f: -f.lowest)
        return [f.name for f in ones if f.get(value)]
