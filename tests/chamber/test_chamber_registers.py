"""A third-party Modbus client (pymodbus's own, not ours) reads and writes the fake chamber per the F4T map.

The addresses and codes below are copied from docs/reference/chamber-map.md on purpose (not read from the
profile), and floats are decoded here with `struct`, so a wrong constant or word order in the fake fails.
"""

from __future__ import annotations

import struct

import pytest
from pymodbus.client import ModbusTcpClient

from fixtures.chamber import ChamberServer, FakeChamber
from rig.clock import SimClock

SET_POINT, WORKING_SET_POINT, PROCESS_VALUE, RAMP_RATE = 2782, 2810, 27586, 2798
DEVICE_STATUS, DISPLAY_UNITS, RAMP_ACTION, RAMP_SCALE, RUN = 90, 1328, 2794, 2796, 16594
OK, UNITS_C, RAMP_OFF, RAMP_ON_SET_POINT, PER_MINUTE, EVENT_OFF, EVENT_ON = 138, 15, 62, 85, 57, 62, 63


def low_word_first(value: float) -> list[int]:
    high, low = struct.unpack(">HH", struct.pack(">f", value))
    return [low, high]


def as_float(words: list[int]) -> float:
    low, high = words
    return struct.unpack(">f", struct.pack(">HH", high, low))[0]


@pytest.fixture()
def served():
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server:
        client = ModbusTcpClient("127.0.0.1", port=server.port, timeout=2)
        assert client.connect()
        yield chamber, clock, client
        client.close()


def read(client, address: int, count: int) -> list[int]:
    rr = client.read_holding_registers(address, count=count, device_id=1)
    assert not rr.isError(), rr
    return list(rr.registers)


def test_identity_units_and_process_value_as_a_foreign_client_reads_them(served):
    chamber, _, client = served
    assert read(client, DEVICE_STATUS, 1) == [OK]
    assert read(client, DISPLAY_UNITS, 1) == [UNITS_C]
    assert as_float(read(client, PROCESS_VALUE, 2)) == pytest.approx(chamber.profile.ambient_c, abs=1e-4)
    assert read(client, RUN, 1) == [EVENT_OFF]


def test_a_foreign_client_runs_the_chamber_and_the_air_moves(served):
    chamber, clock, client = served
    assert not client.write_registers(RAMP_RATE, low_word_first(5.0), device_id=1).isError()
    assert not client.write_register(RAMP_SCALE, PER_MINUTE, device_id=1).isError()
    assert not client.write_register(RAMP_ACTION, RAMP_ON_SET_POINT, device_id=1).isError()
    assert not client.write_registers(SET_POINT, low_word_first(40.0), device_id=1).isError()
    assert not client.write_register(RUN, EVENT_ON, device_id=1).isError()
    assert as_float(read(client, SET_POINT, 2)) == pytest.approx(40.0, abs=1e-5)
    clock.sleep(60.0)
    working = as_float(read(client, WORKING_SET_POINT, 2))
    assert working == pytest.approx(23.0 + 5.0, abs=1e-3), "one minute of a 5 C/min ramp"
    air = as_float(read(client, PROCESS_VALUE, 2))
    assert 23.0 < air < working


def test_exception_replies_for_what_the_map_does_not_allow(served):
    _, _, client = served
    assert client.read_holding_registers(2784, count=2, device_id=1).exception_code == 2      # not in the map
    assert client.write_registers(PROCESS_VALUE, low_word_first(50.0), device_id=1).exception_code == 2  # R only
    assert client.write_register(SET_POINT, 0, device_id=1).exception_code == 3              # half a float
    assert client.write_register(RAMP_ACTION, 999, device_id=1).exception_code == 3          # no such value
    assert client.write_registers(SET_POINT, low_word_first(500.0), device_id=1).exception_code == 3
