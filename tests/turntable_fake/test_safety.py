"""Heartbeat, comms watchdog and the latching software e-stop."""

from __future__ import annotations

import pytest

from .conftest import (ALARM, ALARM_RESET, AXIS, ENABLE, ENABLED, ESTOP, MOVE_ABS, MOVE_VEL, MOVING, Axis)

SYS_STATUS, HEARTBEAT, WATCHDOG_MS, SYS_COMMAND = 2, 3, 4, 5
READY, SYS_ESTOP, ANY_ALARM, WATCHDOG = 1, 2, 4, 8


def sys_regs(client) -> list[int]:
    return client.read_holding_registers(0, count=6, device_id=1).registers


def test_heartbeat_counts_at_10_hz_of_the_injected_clock_and_wraps(client, clock):
    h0 = sys_regs(client)[HEARTBEAT]
    clock.sleep(1.0)
    assert sys_regs(client)[HEARTBEAT] == (h0 + 10) & 0xFFFF
    clock.sleep(0.35)
    assert sys_regs(client)[HEARTBEAT] in ((h0 + 13) & 0xFFFF, (h0 + 14) & 0xFFFF)
    before = sys_regs(client)[HEARTBEAT]
    clock.sleep(6553.6)
    assert sys_regs(client)[HEARTBEAT] == before, "u16 wraps after 65536 ticks"


def test_watchdog_trips_at_the_right_time_and_reset_clears(client, clock, tt):
    ax0, ax1 = Axis(client, 0), Axis(client, 1)
    client.write_register(WATCHDOG_MS, 500, device_id=1)
    for ax in (ax0, ax1):
        ax.write(ENABLE, 1)
        ax.profile(0, 20_000, 40_000)
        ax.command(MOVE_VEL)
    for _ in range(10):  # polling at 5 Hz keeps it quiet
        clock.sleep(0.2)
        assert not sys_regs(client)[SYS_STATUS] & WATCHDOG
    pos_last = ax0.feedback()["pos"]
    assert ax0.feedback()["vel"] == 20_000
    clock.sleep(2.0)
    # track read by the world applies the trip without any request
    _, rates, _ = tt.track.angles(clock.now())
    assert list(rates) == [0.0, 0.0]
    regs = sys_regs(client)
    assert regs[SYS_STATUS] & WATCHDOG and regs[SYS_STATUS] & ANY_ALARM and not regs[SYS_STATUS] & READY
    for ax in (ax0, ax1):
        fb = ax.feedback()
        assert fb["alarm"] == 5 and fb["status"] & ALARM and not fb["status"] & MOVING
    # tripped 0.5 s after the last request at 20 deg/s, then v^2/2d = 5 deg of braking
    assert ax0.feedback()["pos"] == pytest.approx(pos_last + 10_000 + 5_000, abs=1)
    assert ax0.command(MOVE_ABS).exception_code == 4
    assert ax0.feedback()["last_error"] == 1
    client.write_register(SYS_COMMAND, 2, device_id=1)
    regs = sys_regs(client)
    assert regs[SYS_STATUS] == READY and regs[SYS_COMMAND] == 0
    assert ax0.feedback()["alarm"] == 0 and ax1.feedback()["alarm"] == 0


def test_watchdog_off_by_default(client, clock, ax0):
    ax0.write(ENABLE, 1)
    clock.sleep(100.0)
    assert sys_regs(client)[SYS_STATUS] == READY
    assert ax0.feedback()["alarm"] == 0


def test_alarm_reset_per_axis_clears_the_watchdog_flag_once_no_axis_has_it(client, clock):
    client.write_register(WATCHDOG_MS, 100, device_id=1)
    clock.sleep(1.0)
    client.write_register(WATCHDOG_MS, 0, device_id=1)
    Axis(client, 0).command(ALARM_RESET)
    assert sys_regs(client)[SYS_STATUS] & WATCHDOG, "axis 1 still has alarm 5"
    Axis(client, 1).command(ALARM_RESET)
    assert sys_regs(client)[SYS_STATUS] == READY


def test_software_estop_halts_at_once_latches_and_resets(client, clock, tt):
    ax0, ax1 = Axis(client, 0), Axis(client, 1)
    ax0.write(ENABLE, 1)
    ax0.profile(180_000, 40_000, 80_000)
    ax0.command(MOVE_ABS)
    clock.sleep(1.0)
    assert not client.write_register(SYS_COMMAND, 1, device_id=1).isError()
    t_stop = clock.now()
    frozen = ax0.feedback()["pos"]
    clock.sleep(5.0)
    regs = sys_regs(client)
    assert regs[SYS_COMMAND] == 0, "self-clearing"
    assert regs[SYS_STATUS] & SYS_ESTOP and not regs[SYS_STATUS] & READY
    fb = ax0.feedback()
    assert fb["pos"] == frozen and fb["vel"] == 0 and fb["status"] & ESTOP and not fb["status"] & ENABLED
    assert ax1.feedback()["status"] & ESTOP
    assert tt.track.angles(t_stop + 2.0)[0][0] == pytest.approx(frozen / 1000.0, abs=1e-3)
    assert ax0.write(ENABLE, 1).exception_code == 4, "no servo-on while the e-stop is latched"
    assert ax0.command(MOVE_ABS).exception_code == 4
    assert ax0.feedback()["last_error"] == 1
    client.write_register(SYS_COMMAND, 2, device_id=1)
    assert sys_regs(client)[SYS_STATUS] == READY
    ax0.write(ENABLE, 1)
    assert not ax0.command(MOVE_ABS).isError()
    clock.sleep(6.0)
    assert ax0.feedback()["pos"] == 180_000


def test_sys_command_reads_zero_and_global_block_address_check(client):
    assert client.write_register(SYS_COMMAND, 3, device_id=1).exception_code == 3
    assert client.read_holding_registers(AXIS[0] - 1, count=1, device_id=1).exception_code == 2
