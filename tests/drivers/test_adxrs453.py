"""ADXRS453 frame-level tests: command words, parity, one-frame latency, CHK start-up, every fault path."""

from __future__ import annotations

import errno

import pytest

from drivers import ADXRS453, BusError, DeviceAbsent, GyroTriad, ProtocolError, SensorFault, WrongIdentity
from drivers.adxrs453 import read_command, with_parity, write_command
from tests.drivers.conftest import expected_protocol, frame, with_p0_p1, with_p1

SD = 0x20000000


def rate_response(counts: int, faults: int = 0, st: int = 1) -> int:
    return with_p0_p1((st << 26) | ((counts & 0xFFFF) << 10) | faults)


def read_response(value: int) -> int:
    return with_p0_p1((0b010 << 29) | (3 << 26) | ((value & 0xFFFF) << 5))


CHK_ALL = 0x080000FF   # ST = 10, all fault bits set, P0/P1 valid (registers.md 4.3 example)
START = [frame(0x20000003, 0x00000001),
         frame(SD, with_p0_p1(0x08000000 | 0x0E)),
         frame(SD, CHK_ALL),
         frame(SD, CHK_ALL),
         frame(0x80180000, rate_response(0)),            # read PID; answers the last sensor-data request
         frame(0x80140000, read_response(0x5202)),       # read FAULT; answers PID
         frame(SD, read_response(0x0000))]               # answers FAULT


@pytest.mark.parametrize("reg, word", [(0x00, 0x80000000), (0x02, 0x80040001), (0x04, 0x80080001),
                                       (0x06, 0x800C0000), (0x08, 0x80100001), (0x0A, 0x80140000),
                                       (0x0C, 0x80180000), (0x0E, 0x801C0001), (0x10, 0x80200001)])
def test_read_command_words_match_table(reg, word):
    assert read_command(reg) == word


def test_chk_and_write_words_have_odd_parity():
    assert with_parity(SD | 0x2) == 0x20000003
    word = write_command(0x12, 0x0155)
    assert word >> 29 == 0b010 and (word >> 17) & 0x1FF == 0x12 and (word >> 1) & 0xFFFF == 0x0155
    assert word.bit_count() % 2 == 1


def started(spi, sleeps) -> ADXRS453:
    gyro = ADXRS453(spi, sleep=sleeps)
    gyro.start()
    return gyro


def test_start_up_sequence(sleeps):
    with expected_protocol("spi", START) as spi:
        gyro = started(spi, sleeps)
    assert sleeps == [0.1, 0.05, 0.05, 0.05]
    assert gyro.part_id == 0x5202


def test_restart_without_power_cycle_accepts_any_well_formed_first_frame(sleeps):
    with expected_protocol("spi", [frame(0x20000003, rate_response(12))] + START[1:]) as spi:
        started(spi, sleeps)


@pytest.mark.parametrize("stuck", [0x00000000, 0xFFFFFFFF])
def test_absent_chip(stuck, sleeps):
    with expected_protocol("spi", [frame(0x20000003, stuck)]) as spi:
        with pytest.raises(DeviceAbsent, match=f"ADXRS453 on SPI 0.0: frame 0x{stuck:08X}"):
            started(spi, sleeps)


@pytest.mark.parametrize("bad", [rate_response(0, st=2),                  # ST = 10 but no fault bits
                                 with_p0_p1(0x08000000 | 0x7E),           # PLL flag missing
                                 rate_response(0)])                       # normal data: CHK had no effect
def test_chk_self_check_must_show_st10_with_all_faults(bad, sleeps):
    with expected_protocol("spi", START[:2] + [frame(SD, bad)]) as spi:
        with pytest.raises(SensorFault, match="CHK self-check failed"):
            started(spi, sleeps)


def test_start_up_wants_normal_data_after_chk(sleeps):
    steps = START[:4] + [frame(0x80180000, rate_response(0, faults=0x04))]
    with expected_protocol("spi", steps) as spi:
        with pytest.raises(SensorFault, match=r"fault bits set: CST"):
            started(spi, sleeps)


def test_wrong_part_id(sleeps):
    steps = START[:5] + [frame(0x80140000, read_response(0x5100))]
    with expected_protocol("spi", steps) as spi:
        with pytest.raises(WrongIdentity, match=r"register 0x0C PID: read 0x5100, expected 0x52xx"):
            started(spi, sleeps)


def test_fault_register_must_be_clear(sleeps):
    steps = START[:6] + [frame(SD, read_response(0x0090))]
    with expected_protocol("spi", steps) as spi:
        with pytest.raises(SensorFault, match=r"0x0A FAULT: 0x0090 \(PLL, POR\)"):
            started(spi, sleeps)


@pytest.mark.parametrize("counts", [0, 80, -80, 24000, -24000, 32767, -32768])
def test_read_raw_one_frame_per_sample(counts, sleeps):
    with expected_protocol("spi", START + [frame(SD, rate_response(counts))]) as spi:
        assert started(spi, sleeps).read_raw() == counts


@pytest.mark.parametrize("word, error, match", [
    (rate_response(100) ^ 0x1, ProtocolError, "P1 parity error"),
    (rate_response(100) ^ (1 << 28) ^ 0x1, ProtocolError, "P0 parity error"),
    (rate_response(100, st=0), SensorFault, r"ST = 00 \(invalid data\)"),
    (rate_response(100, st=2), SensorFault, r"ST = 10 \(self-test data\)"),
    (rate_response(100, faults=0x80), SensorFault, "fault bits set: PLL"),
    (rate_response(100, faults=0x7E), SensorFault, "Q, NVM, POR, PWR, CST, CHK"),
    (with_p0_p1((3 << 26) | (1 << 18)), ProtocolError, r"R/W error response: SE \(SPI error\)"),
    (with_p0_p1((3 << 26) | (1 << 16)), ProtocolError, r"DU \(data unavailable\)"),
    (read_response(0x1234), ProtocolError, "unexpected response type 010"),
])
def test_bad_data_frames_never_become_numbers(word, error, match, sleeps):
    with expected_protocol("spi", START + [frame(SD, word)]) as spi:
        gyro = started(spi, sleeps)
        with pytest.raises(error, match=match) as info:
            gyro.read_raw()
    assert f"0x{word:08X}" in str(info.value)


@pytest.mark.parametrize("t10, celsius", [(0, 45.0), (50, 55.0), (-25, 40.0), (-225, 0.0)])
def test_temperature_read_uses_pipeline(t10, celsius, sleeps):
    tem = (t10 << 6) & 0xFFFF
    steps = START + [frame(0x80040001, rate_response(5)), frame(SD, read_response(tem)),
                     frame(SD, rate_response(7))]
    with expected_protocol("spi", steps) as spi:
        gyro = started(spi, sleeps)
        assert gyro.read_temperature() == pytest.approx(celsius)
        assert gyro.read_raw() == 7


def test_read_error_response_names_register(sleeps):
    steps = START + [frame(0x80040001, rate_response(0)), frame(SD, with_p0_p1((3 << 26) | (1 << 17)))]
    with expected_protocol("spi", steps) as spi:
        gyro = started(spi, sleeps)
        with pytest.raises(ProtocolError, match=r"read of register 0x02 TEM .*RE \(request error\)"):
            gyro.read_temperature()


def test_pipeline_recovers_after_a_failed_register_read(sleeps):
    steps = START + [frame(0x80040001, rate_response(0, faults=0x08)),   # answer to the last SD: PWR fault
                     frame(SD, read_response(50 << 6)),                   # flushes the TEM answer
                     frame(SD, rate_response(-3))]
    with expected_protocol("spi", steps) as spi:
        gyro = started(spi, sleeps)
        with pytest.raises(SensorFault, match="PWR"):
            gyro.read_temperature()
        assert gyro.read_raw() == -3


def test_register_read_validation():
    with pytest.raises(ValueError, match="unknown register 0x03; allowed: 0x00 RATE"):
        ADXRS453(object()).read_register(0x03)
    with pytest.raises(ValueError, match="not writable; allowed: 0x12 DNC"):
        ADXRS453(object()).write_register(0x02, 1)


def test_triad_reads_three_chips_fresh(sleeps):
    """Each chip gets a priming frame whose (stale) answer is dropped, then the frame with the rate latched now."""
    rates, stale = (11, -22, 33), rate_response(999)
    with expected_protocol("spi", START + [frame(SD, stale), frame(SD, rate_response(rates[0]))]) as sx, \
         expected_protocol("spi", START + [frame(SD, stale), frame(SD, rate_response(rates[1]))]) as sy, \
         expected_protocol("spi", START + [frame(SD, stale), frame(SD, rate_response(rates[2]))]) as sz:
        triad = GyroTriad([ADXRS453(s, cs=f"cs{i}", sleep=sleeps) for i, s in enumerate((sx, sy, sz))])
        triad.start()
        assert triad.read_raw() == rates


def test_triad_needs_three():
    with pytest.raises(ValueError, match="exactly 3"):
        GyroTriad([ADXRS453(object())] * 2)


def test_settings_scale():
    assert ADXRS453(object()).settings()["scale"] == pytest.approx(218166e-9, rel=1e-5)


def test_helper_parity_sanity():
    assert with_p1(0x080000FE) == CHK_ALL


def write_response(value: int) -> int:
    return with_p0_p1((0b001 << 29) | (3 << 26) | ((value & 0xFFFF) << 5))


def test_write_dnc_checks_the_write_response(sleeps):
    cmd = write_command(0x12, 0x0010)
    steps = START + [frame(cmd, rate_response(0)), frame(SD, write_response(0x0010))]
    with expected_protocol("spi", steps) as spi:
        started(spi, sleeps).write_register(0x12, 0x0010)


def test_write_answered_by_read_response_is_protocol_error(sleeps):
    cmd = write_command(0x12, 0x0010)
    steps = START + [frame(cmd, rate_response(0)), frame(SD, read_response(0x0010))]
    with expected_protocol("spi", steps) as spi:
        with pytest.raises(ProtocolError, match=r"write of register 0x12 DNC.*expected a write response"):
            started(spi, sleeps).write_register(0x12, 0x0010)


def test_spi_oserror_is_bus_error_naming_frame(sleeps):
    with expected_protocol("spi", START + [("x", (0x20, 0, 0, 0), OSError(errno.EIO, "I/O error"))]) as spi:
        with pytest.raises(BusError, match=r"ADXRS453 on SPI 0.0: frame 0x20000000 failed"):
            started(spi, sleeps).read_raw()
