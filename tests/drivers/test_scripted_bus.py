"""The scripted fake buses must catch wrong, extra and missing transactions, or driver tests prove nothing."""

from __future__ import annotations

import pytest

from tests.drivers.conftest import expected_protocol


def test_differing_transaction_fails():
    with pytest.raises(AssertionError, match=r"transaction 0: expected \('r', 83, 0\), got \('r', 83, 1\)"):
        with expected_protocol("i2c", [("r", 0x53, 0x00, 0xE5)]) as bus:
            bus.read_byte_data(0x53, 0x01)


def test_extra_transaction_fails():
    with pytest.raises(AssertionError, match="unexpected transaction"):
        with expected_protocol("spi", []) as spi:
            spi.xfer2([0x06, 0x00, 0x00])


def test_left_over_transactions_fail():
    with pytest.raises(AssertionError, match="1 expected transactions not made"):
        with expected_protocol("i2c", [("w", 0x68, 0x3E, 0x80, None)]):
            pass


def test_spi_fake_rejects_keyword_arguments_like_spidev():
    with expected_protocol("spi", [("x", (1,), [0])]) as spi:
        with pytest.raises(TypeError):
            spi.xfer2([1], speed_hz=5)
        spi.xfer2([1])


def test_block_reads_over_32_bytes_rejected_like_smbus2():
    with expected_protocol("i2c", []) as bus:
        with pytest.raises(ValueError, match="over 32"):
            bus.read_i2c_block_data(0x53, 0x32, 33)
