"""Scripted byte-level fake buses in the style of PyMeasure's `expected_protocol`.

A test lists the transactions a driver must make, each with the bytes to return (or an exception to raise).
The fake fails on the first transaction that differs, and `expected_protocol` fails if any are left over.
The fakes keep the real signatures: smbus2 methods take an optional `force`, spidev's xfer2 is positional-only.
"""

from __future__ import annotations

import errno
from contextlib import contextmanager
from typing import Any, Iterator

import pytest


class Script:
    """Expected transactions, consumed in order."""

    def __init__(self, steps: list[tuple]) -> None:
        self.steps = list(steps)
        self.done = 0

    def take(self, *call: Any) -> Any:
        if self.done >= len(self.steps):
            raise AssertionError(f"unexpected transaction {call!r} after all {len(self.steps)} expected ones")
        step = self.steps[self.done]
        expected, result = step[:-1], step[-1]
        if tuple(call) != tuple(expected):
            raise AssertionError(f"transaction {self.done}: expected {expected!r}, got {tuple(call)!r}")
        self.done += 1
        if isinstance(result, BaseException):
            raise result
        return result

    def assert_done(self) -> None:
        left = self.steps[self.done:]
        assert not left, f"{len(left)} expected transactions not made, first: {left[0][:-1]!r}"


class ScriptedSMBus:
    """smbus2.SMBus look-alike driven by a Script. Steps:
    ("r", addr, reg, value) read_byte_data; ("w", addr, reg, value, None) write_byte_data;
    ("rb", addr, reg, n, [bytes]) read_i2c_block_data; ("wb", addr, reg, (bytes), None) write_i2c_block_data.
    """

    def __init__(self, script: Script) -> None:
        self.script = script

    def read_byte_data(self, i2c_addr: int, register: int, force: Any = None) -> int:
        return self.script.take("r", i2c_addr, register)

    def write_byte_data(self, i2c_addr: int, register: int, value: int, force: Any = None) -> None:
        return self.script.take("w", i2c_addr, register, value)

    def read_i2c_block_data(self, i2c_addr: int, register: int, length: int, force: Any = None) -> list:
        if length > 32:
            raise ValueError("Desired block length over 32 bytes")
        return list(self.script.take("rb", i2c_addr, register, length))

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: list, force: Any = None) -> None:
        if len(data) > 32:
            raise ValueError("Data length cannot exceed 32 bytes")
        return self.script.take("wb", i2c_addr, register, tuple(data))


class ScriptedSpi:
    """spidev.SpiDev look-alike: ("x", (tx bytes), [rx bytes]) per xfer2 frame."""

    def __init__(self, script: Script) -> None:
        self.script = script
        self.label = "0.0"

    def xfer2(self, values: list, speed_hz: int = 0, delay_usecs: int = 0, bits_per_word: int = 0, /) -> list:
        rx = list(self.script.take("x", tuple(values)))
        assert len(rx) == len(values), f"scripted reply {rx} has a different length than {values}"
        return rx


@contextmanager
def expected_protocol(kind: str, steps: list[tuple]) -> Iterator[Any]:
    """Yield a scripted I2C ("i2c") or SPI ("spi") bus; on exit every expected transaction must be made."""
    script = Script(steps)
    yield ScriptedSMBus(script) if kind == "i2c" else ScriptedSpi(script)
    script.assert_done()


def nack() -> OSError:
    return OSError(errno.EREMOTEIO, "Remote I/O error")


def word_bytes(word: int) -> list[int]:
    return list(word.to_bytes(4, "big"))


def frame(command: int, response: int) -> tuple:
    """One ADXRS453 32-bit frame step."""
    return ("x", tuple(word_bytes(command)), word_bytes(response))


def with_p1(word: int) -> int:
    """Fix bit 0 so the whole response word has odd parity (P1)."""
    word &= ~1
    return word if word.bit_count() & 1 else word | 1


def with_p0_p1(word: int) -> int:
    """Set P0 (bit 28) so bits 31:16 are odd, then P1: a well-formed ADXRS453 response."""
    word &= ~(1 << 28)
    if not (word >> 16).bit_count() & 1:
        word |= 1 << 28
    return with_p1(word)


class SleepLog(list):
    """Records requested sleeps instead of sleeping."""

    def __call__(self, seconds: float) -> None:
        self.append(seconds)


@pytest.fixture
def sleeps() -> SleepLog:
    return SleepLog()
