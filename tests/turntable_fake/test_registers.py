"""Identity, exception codes and command-register semantics, over every transport."""

from __future__ import annotations

import pytest
from pymodbus.exceptions import ModbusIOException

from fixtures.turntable import TurntableServer

from .conftest import (ALARM_RESET, AXIS, CMD_REJECTED, COMMAND, ENABLE, MOVE_ABS, MOVE_REL, SET_ZERO,
                       SOFT_LIMIT_NEG, SOFT_LIMIT_POS, STOP, Axis, connect)


@pytest.mark.parametrize("transport", ["tcp", "rtu-tcp", "rtu-pty"])
def test_identity_and_a_move_over_each_transport(tt, clock, transport):
    with TurntableServer(tt, transport=transport) as srv:
        c = connect(srv)
        try:
            rr = c.read_holding_registers(0, count=6, device_id=1)
            assert rr.registers[:2] == [0x5454, 0x0100]
            assert rr.registers[2] & 1, "ready bit"
            ax = Axis(c, 1)
            assert not ax.write(ENABLE, 1).isError()
            ax.profile(-12345, 50_000, 100_000)
            assert not ax.command(MOVE_ABS).isError()
            clock.sleep(2.0)
            fb = ax.feedback()
            assert fb["pos"] == -12345 and fb["seq"] == 1
        finally:
            c.close()


def test_url_names_the_transport(tt):
    with TurntableServer(tt, transport="tcp") as srv:
        assert srv.url == f"tcp://127.0.0.1:{srv.port}" and srv.port > 0
    with TurntableServer(tt, transport="rtu-tcp") as srv:
        assert srv.url == f"rtu+socket://127.0.0.1:{srv.port}"
    with TurntableServer(tt, transport="rtu-pty") as srv:
        assert srv.client_port.startswith("/dev/pts/")
        assert srv.url == f"rtu://{srv.client_port}?baud=115200&parity=N"


def test_refuses_non_loopback_bind_without_allow_remote(tt):
    with pytest.raises(ValueError, match="non-loopback"):
        TurntableServer(tt, host="0.0.0.0")


def test_servers_start_and_stop_one_after_another(tt):
    for transport in ("tcp", "rtu-pty", "tcp", "rtu-tcp", "rtu-pty"):
        with TurntableServer(tt, transport=transport) as srv:
            c = connect(srv)
            assert c.read_holding_registers(0, count=1, device_id=1).registers == [0x5454]
            c.close()


def test_undefined_addresses_answer_02(client):
    for address, count in [(0x0006, 1), (0x0000, 7), (0x010E, 1), (0x011C, 1), (0x0300, 1), (0x00FF, 2)]:
        rr = client.read_holding_registers(address, count=count, device_id=1)
        assert rr.isError() and rr.exception_code == 2, (hex(address), count)


def test_writes_to_read_only_registers_answer_02(client):
    for address in (0x0000, 0x0001, 0x0002, 0x0003, 0x0110, 0x0118, 0x021B):
        rr = client.write_register(address, 1, device_id=1)
        assert rr.isError() and rr.exception_code == 2, hex(address)
    rr = client.write_registers(0x010C, [0, 0, 0, 0, 0, 0], device_id=1)  # spans RW, hole and RO
    assert rr.exception_code == 2


def test_other_function_codes_answer_01(client):
    assert client.read_input_registers(0, count=1, device_id=1).exception_code == 1
    assert client.read_coils(0, count=1, device_id=1).exception_code == 1


def test_bad_values_and_unknown_commands_answer_03(client, ax0):
    assert ax0.write(ENABLE, 2).exception_code == 3
    assert ax0.command(7).exception_code == 3
    fb = ax0.feedback()
    assert fb["status"] & CMD_REJECTED and fb["last_error"] == 3
    assert client.write_register(0x0005, 9, device_id=1).exception_code == 3  # SYS_COMMAND
    ax0.write(ENABLE, 1)
    ax0.profile(1000, 0, 1000)  # zero profile speed
    assert ax0.command(MOVE_ABS).exception_code == 3
    ax0.profile(1000, 1000, 0)  # zero acceleration
    assert ax0.command(MOVE_ABS).exception_code == 3
    assert ax0.feedback()["seq"] == 0


def test_target_beyond_soft_limits_answers_03_with_out_of_limits(client, ax0, clock):
    ax0.write(ENABLE, 1)
    ax0.write32(SOFT_LIMIT_POS, 90_000)
    ax0.write32(SOFT_LIMIT_NEG, -10_000)
    ax0.profile(90_001, 10_000, 10_000)
    assert ax0.command(MOVE_ABS).exception_code == 3
    fb = ax0.feedback()
    assert fb["last_error"] == 2 and fb["status"] & CMD_REJECTED
    ax0.profile(-10_001, 10_000, 10_000)
    assert ax0.command(MOVE_ABS).exception_code == 3
    ax0.profile(90_000, 90_000, 90_000)
    assert not ax0.command(MOVE_ABS).isError()
    fb = ax0.feedback()
    assert fb["last_error"] == 0 and not fb["status"] & CMD_REJECTED, "cleared by an accepted command"
    clock.sleep(3.0)
    ax0.profile(1, 10_000, 10_000)
    assert ax0.command(MOVE_REL).exception_code == 3, "90 deg + 1 mdeg relative is beyond the limit"
    assert ax0.write32(SOFT_LIMIT_NEG, 100_000).exception_code == 3, "negative limit above positive"


def test_commands_refused_while_disabled_answer_04(ax0):
    ax0.profile(1000, 1000, 1000)
    rr = ax0.command(MOVE_ABS)
    assert rr.isError() and rr.exception_code == 4
    fb = ax0.feedback()
    assert fb["status"] & CMD_REJECTED and fb["last_error"] == 1 and fb["seq"] == 0


def test_command_register_is_self_clearing_and_cmd_seq_counts_accepted_commands(client, ax0, ax1):
    ax0.write(ENABLE, 1)
    ax0.profile(5000, 10_000, 10_000)
    rr = ax0.command(MOVE_ABS)
    assert rr.registers == [0], "the FC06 echo already shows the cleared command register"
    assert client.read_holding_registers(AXIS[0] + COMMAND, count=1, device_id=1).registers == [0]
    for code in (STOP, ALARM_RESET):
        assert not ax0.command(code).isError()
    ax0.command(99)  # rejected: not counted
    assert ax0.feedback()["seq"] == 3
    assert ax1.feedback()["seq"] == 0, "per-axis counter"


def test_command_and_parameters_in_one_fc16_are_applied_together(client, clock):
    base = AXIS[0]
    c = client
    regs = ([1, 1] + c.convert_to_registers(20_000, c.DATATYPE.INT32) + c.convert_to_registers(40_000, c.DATATYPE.INT32)
            + c.convert_to_registers(80_000, c.DATATYPE.INT32))
    assert not c.write_registers(base, regs, device_id=1).isError()
    clock.sleep(2.0)
    fb = Axis(c, 0).feedback()
    assert fb["pos"] == 20_000 and fb["seq"] == 1
    assert c.read_holding_registers(base, count=2, device_id=1).registers == [1, 0]


def test_set_zero_redefines_position_and_refuses_while_moving(ax0, clock):
    ax0.write(ENABLE, 1)
    ax0.profile(30_000, 30_000, 60_000)
    ax0.command(MOVE_ABS)
    clock.sleep(0.2)
    assert ax0.command(SET_ZERO).exception_code == 4
    clock.sleep(3.0)
    counts_before = ax0.feedback()["counts"]
    assert not ax0.command(SET_ZERO).isError()
    fb = ax0.feedback()
    assert fb["pos"] == 0 and fb["counts"] == counts_before, "raw counts keep the physical angle"
    ax0.profile(-30_000, 30_000, 60_000)
    ax0.command(MOVE_ABS)
    clock.sleep(3.0)
    assert ax0.feedback()["pos"] == -30_000
    assert abs(ax0.feedback()["counts"]) <= 1, "back at physical zero"


def test_wrong_device_id_is_silent_on_rtu_and_0x0b_on_tcp(tt):
    with TurntableServer(tt, transport="rtu-tcp") as srv:
        c = connect(srv, timeout=0.3)
        with pytest.raises(ModbusIOException):
            c.read_holding_registers(0, count=1, device_id=7)
        c.close()
    with TurntableServer(tt, transport="tcp") as srv:
        c = connect(srv)
        assert c.read_holding_registers(0, count=1, device_id=7).exception_code == 0x0B
        assert c.write_register(AXIS[0] + ENABLE, 1, device_id=7).exception_code == 0x0B
        assert c.read_holding_registers(AXIS[0] + ENABLE, count=1, device_id=1).registers == [0], \
            "a write to another id must not reach the turntable"
        c.close()
