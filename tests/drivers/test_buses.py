"""Bus openers: spidev is optional and must be imported lazily with a clear message."""

from __future__ import annotations

import errno
import sys
import types

import pytest

from drivers import buses


def test_open_spi_without_spidev_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "spidev", None)
    with pytest.raises(ImportError, match=r"rig\[spi\]"):
        buses.open_spi(0, 0, 3, 5_000_000)


def test_open_spi_sets_mode_and_speed_after_open(monkeypatch):
    class SpiDev:                      # real spidev refuses attribute writes before open() with EBADF
        def __init__(self):
            self.opened = None

        def open(self, bus, device):
            self.opened = (bus, device)

        def __setattr__(self, name, value):
            if name != "opened" and self.opened is None:
                raise OSError(errno.EBADF, "Bad file descriptor")
            object.__setattr__(self, name, value)

    monkeypatch.setitem(sys.modules, "spidev", types.SimpleNamespace(SpiDev=SpiDev))
    spi = buses.open_spi(0, 1, 3, 5_000_000)
    assert (spi.opened, spi.mode, spi.max_speed_hz) == ((0, 1), 3, 5_000_000)


def test_open_spi_rejects_bad_mode(monkeypatch):
    monkeypatch.setitem(sys.modules, "spidev", types.SimpleNamespace(SpiDev=object))
    with pytest.raises(ValueError, match="mode"):
        buses.open_spi(0, 0, 4, 1_000_000)


def test_open_i2c_missing_adapter_raises_oserror():
    with pytest.raises(OSError):
        buses.open_i2c(250)
