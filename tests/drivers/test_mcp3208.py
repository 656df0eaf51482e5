"""MCP3208 byte-level tests: 3-byte command frames, result decoding, null-bit and absence checks."""

from __future__ import annotations

import errno

import pytest

from drivers import MCP3208, BusError, DeviceAbsent, ProtocolError
from tests.drivers.conftest import expected_protocol

SINGLE = {0: (0x06, 0x00), 1: (0x06, 0x40), 2: (0x06, 0x80), 3: (0x06, 0xC0),
          4: (0x07, 0x00), 5: (0x07, 0x40), 6: (0x07, 0x80), 7: (0x07, 0xC0)}


@pytest.mark.parametrize("channel", range(8))
def test_single_ended_command_bytes(channel):
    b0, b1 = SINGLE[channel]
    with expected_protocol("spi", [("x", (b0, b1, 0x00), [0x00, 0x0A, 0xBC])]) as spi:
        assert MCP3208(spi).read(channel) == 0xABC


@pytest.mark.parametrize("rx, code", [([0x00, 0x00, 0x00], 0), ([0x00, 0x0F, 0xFF], 4095),
                                      ([0xFF, 0xE8, 0x00], 2048)])   # bits 7:5 of byte 1 are don't-care
def test_result_decoding_ignores_undriven_bits(rx, code):
    with expected_protocol("spi", [("x", (0x06, 0x00, 0x00), rx)]) as spi:
        assert MCP3208(spi).read(0) == code


def test_differential_pair_command_bytes():
    with expected_protocol("spi", [("x", (0x04, 0x40, 0x00), [0, 0x01, 0x23]),
                                   ("x", (0x05, 0xC0, 0x00), [0, 0x00, 0x07])]) as spi:
        adc = MCP3208(spi)
        assert adc.read_differential(1) == 0x123
        assert adc.read_differential(7) == 7


def test_high_null_bit_is_protocol_error():
    with expected_protocol("spi", [("x", (0x06, 0x40, 0x00), [0x00, 0x1A, 0xBC])]) as spi:
        with pytest.raises(ProtocolError, match=r"MCP3208 on SPI 0.0, channel 1: TX 06 40 00, RX 00 1A BC"):
            MCP3208(spi).read(1)


def test_miso_stuck_high_is_absent_adc():
    with expected_protocol("spi", [("x", (0x06, 0x00, 0x00), [0xFF, 0xFF, 0xFF])]) as spi:
        with pytest.raises(DeviceAbsent, match="stuck high"):
            MCP3208(spi, cs="spidev0.0").start()


@pytest.mark.parametrize("channel", [8, -1, "1", 1.0, None])
def test_channel_validation(channel):
    with pytest.raises(ValueError, match="allowed: 0..7"):
        MCP3208(object()).read(channel)


def test_pair_validation_lists_pairs():
    with pytest.raises(ValueError, match=r"allowed: 0 \(CH0\+/CH1-\)"):
        MCP3208(object()).read_differential(8)


def test_voltage_uses_vref():
    with expected_protocol("spi", [("x", (0x06, 0x00, 0x00), [0, 0x08, 0x00])]) as spi:
        assert MCP3208(spi, vref=5.0).read_voltage(0) == pytest.approx(2.5)


def test_vref_must_be_positive():
    with pytest.raises(ValueError, match="vref"):
        MCP3208(object(), vref=0)


def test_spi_oserror_is_bus_error():
    with expected_protocol("spi", [("x", (0x06, 0x00, 0x00), OSError(errno.EIO, "I/O error"))]) as spi:
        with pytest.raises(BusError, match="MCP3208 on SPI 0.0, channel 0") as info:
            MCP3208(spi).read(0)
    assert not isinstance(info.value, DeviceAbsent)
