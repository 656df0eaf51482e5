"""What every device behind a Modbus link shares: open, identify, and leave it safe however the `with` ends."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TypeVar

from rig.modbus.channel import ModbusChannel

Self = TypeVar("Self", bound="ModbusDevice")


class ModbusDevice(ABC):
    """A context manager around one device on `self.channel`. Subclasses say how the device proves it is the one
    their profile describes (`identify`) and what leaves it safe (`make_safe`); leaving the `with` block always
    does the latter, then closes the link."""

    channel: ModbusChannel

    @abstractmethod
    def identify(self) -> object:
        """Read the device's identity and refuse one that is not what the profile describes."""

    @abstractmethod
    def make_safe(self) -> None:
        """Leave the device where it harms nothing (a table stopped and disabled, a chamber at ambient)."""

    def connect(self: Self) -> Self:
        """Open the link and check the device answering is the one the profile describes."""
        self.channel.open()
        try:
            self.identify()
        except BaseException:
            self.channel.close()
            raise
        return self

    def close(self) -> None:
        self.channel.close()

    def __enter__(self: Self) -> Self:
        return self.connect()

    def __exit__(self, *exc) -> None:
        try:
            self.make_safe()
        finally:
            self.close()
