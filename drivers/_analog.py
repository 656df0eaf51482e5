"""Shared checks for analog sensors read through an ADC."""

from __future__ import annotations

from typing import Any, Sequence

from drivers.errors import DeviceAbsent

ADC_MID = 2048
ADC_MAX = 4095


def validate_channels(channels: Sequence[int], chip: str, n: int = 3) -> tuple[int, ...]:
    channels = tuple(channels)
    if len(channels) != n or len(set(channels)) != n or not all(type(c) is int and 0 <= c <= 7 for c in channels):
        raise ValueError(f"{chip}: channels must be {n} distinct ADC channels in 0..7, got {channels!r}")
    return channels


def check_plausible(adc: Any, channels: Sequence[int], labels: Sequence[str], chip: str) -> None:
    """A code pinned at 0 or full scale means a missing sensor, a broken wire or a missing ADC."""
    for channel, label in zip(channels, labels):
        code = adc.read(channel)
        if code <= 0 or code >= ADC_MAX:
            raise DeviceAbsent(f"{chip} {label} on ADC channel {channel}: code {code} is stuck at a rail "
                               f"(sensor or ADC missing, or wiring fault)")
