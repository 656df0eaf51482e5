"""TCA9548A driver and MuxChannel: bytes on the wire, the select cache, errors naming the switch, and a real chip
driver reading four same-address chips through four channels of the emulated switch."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drivers import ITG3200, DeviceAbsent, SensorFault
from drivers.tca9548a import TCA9548A, MuxChannel
from fixtures.buses import FakeSMBus
from fixtures.chips import ITG3200Emulator
from fixtures.chips.tca9548a import FakeTCA9548A
from fixtures.sources import ConstantSource
from rig.clock import SimClock

SWITCH = 0x70
LSB_PER_DPS = 14.375


class WireLog:
    """Records the one-byte transfers a single-register device sees; reads answer `register`."""

    def __init__(self, register: int = 0x00) -> None:
        self.log: list[tuple] = []
        self.register = register

    def write_byte(self, addr: int, value: int, force=None) -> None:
        self.log.append(("write", addr, value))

    def read_byte(self, addr: int, force=None) -> int:
        self.log.append(("read", addr))
        return self.register


def test_select_writes_one_byte_with_the_channel_bit_and_only_on_change():
    bus = WireLog()
    mux = TCA9548A(bus, 0x75)
    mux.select(2)
    mux.select(2)
    mux.select(7)
    mux.deselect()
    assert mux.selected() is None
    assert bus.log == [("write", 0x75, 0b100), ("write", 0x75, 0b10000000), ("write", 0x75, 0), ("read", 0x75)]
    assert mux.selects == 2


@pytest.mark.parametrize("register, channel", [(0x01, 0), (0x40, 6), (0x00, None)])
def test_selected_reads_the_register_back(register, channel):
    assert TCA9548A(WireLog(register)).selected() == channel


def test_several_channels_on_is_reported_not_guessed():
    with pytest.raises(SensorFault, match=r"0x05 connects channels \[0, 2\]"):
        TCA9548A(WireLog(0x05)).selected()


@pytest.mark.parametrize("address", [0x6F, 0x78, 0x20])
def test_addresses_outside_a2_a0_are_refused(address):
    with pytest.raises(ValueError, match="0x70..0x77"):
        TCA9548A(FakeSMBus(1), address)


def test_a_switch_that_does_not_answer_is_named():
    mux = TCA9548A(FakeSMBus(1), 0x73)
    with pytest.raises(DeviceAbsent, match=r"TCA9548A I2C switch at address 0x73.*select channel 5"):
        MuxChannel(mux.bus, mux, 5).read_byte_data(0x68, 0x00)


def test_a_failed_select_is_written_again_next_time():
    bus = FakeSMBus(1)
    switch = FakeTCA9548A().attach_to(bus, SWITCH)
    mux = TCA9548A(bus, SWITCH)
    bus.nacking.add(SWITCH)
    with pytest.raises(DeviceAbsent):
        mux.select(1)
    bus.nacking.clear()
    mux.select(1)
    assert switch.control == 0x02 and mux.selected() == 1


def four_gyros(clock):
    bus = FakeSMBus(1)
    switch = FakeTCA9548A().attach_to(bus, SWITCH)
    rates_dps = [(10.0, -20.0, 30.0), (-40.0, 50.0, 0.0), (100.0, 0.0, -100.0), (0.0, 7.0, 300.0)]
    for channel, rates in enumerate(rates_dps):
        src = ConstantSource(np.radians(rates))
        switch.downstream(channel).attach(0x68, ITG3200Emulator(src, clock))
    return bus, switch, rates_dps


def test_the_itg3200_driver_reads_four_chips_at_0x68_through_four_channels():
    clock = SimClock()
    bus, switch, rates_dps = four_gyros(clock)
    mux = TCA9548A(bus, SWITCH)
    gyros = [ITG3200(MuxChannel(bus, mux, ch), 0x68, sleep=clock.sleep) for ch in range(4)]
    for g in gyros:
        g.start()
    clock.sleep(0.02)
    for g, rates in zip(gyros, rates_dps):
        counts = g.read_raw()
        for c, r in zip(counts, rates):
            assert c == pytest.approx(r * LSB_PER_DPS, abs=0.5)
    assert switch.conflicts == 0
    assert mux.selected() == 3


def test_a_second_read_on_the_same_channel_writes_no_select():
    clock = SimClock()
    bus, switch, _ = four_gyros(clock)
    mux = TCA9548A(bus, SWITCH)
    gyro = ITG3200(MuxChannel(bus, mux, 2), 0x68, sleep=clock.sleep)
    gyro.start()
    before, written = mux.selects, switch.writes
    gyro.read_raw()
    gyro.read_raw()
    assert (mux.selects, switch.writes) == (before, written) == (1, 1)
    ITG3200(MuxChannel(bus, mux, 0), 0x68, sleep=clock.sleep).read_raw()
    assert (mux.selects, switch.writes) == (2, 2)


def test_chip_errors_behind_the_switch_name_the_chip():
    clock = SimClock()
    bus, _, _ = four_gyros(clock)
    mux = TCA9548A(bus, SWITCH)
    with pytest.raises(DeviceAbsent, match=r"ITG-3200 at I2C address 0x69"):
        ITG3200(MuxChannel(bus, mux, 1), 0x69, sleep=clock.sleep).read_raw()
    assert math.isfinite(ITG3200(MuxChannel(bus, mux, 1), 0x68, sleep=clock.sleep).read_raw()[0])
