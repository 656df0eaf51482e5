"""Every fault hook of `tt.faults`, observed by a raw client."""

from __future__ import annotations

import time

import pytest
from pymodbus.exceptions import ModbusIOException

from fixtures.turntable import TurntableServer

from .conftest import (ALARM, ALARM_RESET, AXIS, ENABLE, ESTOP, IN_POSITION, MOVE_ABS, MOVING, Axis, connect)


@pytest.mark.parametrize("transport", ["tcp", "rtu-tcp"])
def test_dropped_responses_time_out_but_the_request_is_executed(tt, transport):
    with TurntableServer(tt, transport=transport) as srv:
        c = connect(srv, timeout=0.2)
        tt.faults.drop_responses(2)
        with pytest.raises(ModbusIOException):
            c.write_register(AXIS[0] + ENABLE, 1, device_id=1)
        with pytest.raises(ModbusIOException):
            c.read_holding_registers(0, count=1, device_id=1)
        assert c.read_holding_registers(AXIS[0] + ENABLE, count=1, device_id=1).registers == [1]
        assert tt.faults.dropped == 2
        c.close()


def _drop_pattern(tt, server, probability, seed, n=16):
    tt.faults.drop_randomly(probability, seed=seed)
    c = connect(server, timeout=0.15)
    pattern = []
    for _ in range(n):
        try:
            c.read_holding_registers(0, count=1, device_id=1)
            pattern.append(0)
        except ModbusIOException:
            pattern.append(1)
            c.close()
            c = connect(server, timeout=0.15)  # a fresh connection: no late frame in the socket
    c.close()
    tt.faults.clear()
    return pattern


def test_random_drops_are_seeded_and_deterministic(tt, server):
    first = _drop_pattern(tt, server, 0.4, seed=7)
    second = _drop_pattern(tt, server, 0.4, seed=7)
    other = _drop_pattern(tt, server, 0.4, seed=8)
    assert first == second
    assert 2 <= sum(first) <= 12
    assert first != other


def test_delayed_responses(tt, server):
    c = connect(server, timeout=1.0)
    tt.faults.delay_responses(0.25)
    t0 = time.perf_counter()
    assert c.read_holding_registers(0, count=1, device_id=1).registers == [0x5454]
    assert time.perf_counter() - t0 >= 0.25
    tt.faults.delay_responses(0)
    assert c.read_holding_registers(0, count=1, device_id=1).registers == [0x5454]
    c.close()


def test_reply_exception_to_a_function_and_address(tt, client):
    tt.faults.reply_exception(6, function=3, address=AXIS[0] + 0x18, times=2)
    for _ in range(2):
        assert client.read_holding_registers(AXIS[0] + 0x10, count=12, device_id=1).exception_code == 6
    assert client.read_holding_registers(0, count=1, device_id=1).registers == [0x5454], "other address"
    assert not client.read_holding_registers(AXIS[0] + 0x10, count=12, device_id=1).isError(), "used up"
    tt.faults.reply_exception(4, function=6)
    assert client.write_register(AXIS[1] + ENABLE, 1, device_id=1).exception_code == 4
    assert client.read_holding_registers(AXIS[1] + ENABLE, count=1, device_id=1).registers == [0], \
        "the faulted write was not executed"
    tt.faults.clear()
    assert not client.write_register(AXIS[1] + ENABLE, 1, device_id=1).isError()


def test_refused_moves_answer_04_with_the_given_last_error(tt, client):
    ax0, ax1 = Axis(client, 0), Axis(client, 1)
    for ax in (ax0, ax1):
        ax.write(ENABLE, 1)
        ax.profile(1000, 10_000, 10_000)
    tt.faults.refuse_moves(axis=1, last_error=2)
    assert ax1.command(MOVE_ABS).exception_code == 4
    assert ax1.feedback()["last_error"] == 2
    assert not ax0.command(MOVE_ABS).isError(), "only axis 1 refuses"
    tt.faults.clear()
    assert not ax1.command(MOVE_ABS).isError()


def test_never_arrive_stops_short_without_in_position(tt, client, clock):
    ax0 = Axis(client, 0)
    tt.faults.never_arrive(axis=0, short_by_deg=0.5)
    ax0.write(ENABLE, 1)
    ax0.profile(10_000, 10_000, 20_000)
    ax0.command(MOVE_ABS)
    clock.sleep(20.0)
    fb = ax0.feedback()
    assert fb["pos"] == 9_500 and not fb["status"] & MOVING and not fb["status"] & IN_POSITION
    assert fb["ferr"] == 500, "the profile generator reached the target, the axis did not"
    assert tt.track.angles(clock.now())[0][0] == pytest.approx(9.5)


def test_triggered_estop_latches(tt, client, clock):
    tt.faults.trigger_estop()
    clock.sleep(1.0)
    assert client.read_holding_registers(2, count=1, device_id=1).registers[0] & 2
    assert Axis(client, 0).feedback()["status"] & ESTOP


def test_raised_alarm_halts_the_axis_until_reset(tt, client, clock):
    ax0, ax1 = Axis(client, 0), Axis(client, 1)
    ax1.write(ENABLE, 1)
    ax1.profile(90_000, 30_000, 60_000)
    ax1.command(MOVE_ABS)
    clock.sleep(1.0)
    tt.faults.raise_alarm(1, 2)
    frozen = ax1.feedback()["pos"]
    clock.sleep(1.0)
    fb = ax1.feedback()
    assert fb["alarm"] == 2 and fb["status"] & ALARM and fb["pos"] == frozen and fb["vel"] == 0
    assert client.read_holding_registers(2, count=1, device_id=1).registers[0] == 4, "any alarm, not ready"
    assert ax0.feedback()["alarm"] == 0
    assert ax1.command(MOVE_ABS).exception_code == 4
    assert not ax1.command(ALARM_RESET).isError()
    assert ax1.feedback()["alarm"] == 0
    assert not ax1.command(MOVE_ABS).isError()
