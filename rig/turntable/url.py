"""Turntable link URLs: the shared Modbus link URLs (`rig.modbus.url`), named as the turntable's in messages."""

from __future__ import annotations

from rig.modbus.url import LinkAddress
from rig.modbus.url import parse_url as parse_link_url


def parse_url(url: str) -> LinkAddress:
    """Parse a turntable link URL; a bad one raises ValueError naming the offending part."""
    return parse_link_url(url, "turntable")
