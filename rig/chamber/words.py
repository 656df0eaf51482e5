"""32-bit IEEE-754 floats over two 16-bit registers, in either word order."""

from __future__ import annotations

import struct


def float_to_words(value: float, word_order: str) -> list[int]:
    """[first register, second register]; "big": high word first, "little": low word first."""
    high, low = struct.unpack(">HH", struct.pack(">f", value))
    return [high, low] if word_order == "big" else [low, high]


def words_to_float(words: list[int] | tuple[int, int], word_order: str) -> float:
    first, second = words
    high, low = (first, second) if word_order == "big" else (second, first)
    return struct.unpack(">f", struct.pack(">HH", high, low))[0]


def c_to_f(c: float) -> float:
    return c * 1.8 + 32.0


def f_to_c(f: float) -> float:
    return (f - 32.0) / 1.8
