"""TurntableLink against the in-test MiniTable server, over Modbus TCP and RTU framing over TCP."""

from __future__ import annotations

import pytest

from conftest import HOME, MOVE_ABS, MOVE_VEL, STOP
from rig.turntable import (CommunicationError, EStopActive, IdentityError, ModbusExceptionError, MoveRejected,
                           MoveTimeout, TableAlarm, TurntableLink, profile_time)
from rig.turntable.profile import default_profile_path, load_profile


def link_for(srv, clock, **kw) -> TurntableLink:
    kw.setdefault("timeout", 0.1)
    return TurntableLink(srv.url, clock=clock, **kw)


def test_full_move_protocol(server, table, clock):
    with link_for(server, clock) as link:
        assert link.identify() == (0x5454, 0x0100)
        link.enable()
        t0 = clock.now()
        final = link.move_to(40.0, -25.0, speed_dps=20.0, accel_dps2=40.0, settle_s=0.2)
        elapsed = clock.now() - t0
        assert [round(s.position_deg, 3) for s in final] == [40.0, -25.0]
        assert all(s.has("IN_POSITION") and s.cmd_seq == 1 for s in final)
        assert link.positions() == (40.0, -25.0)
        assert table.commands == [(0, MOVE_ABS), (1, MOVE_ABS)]
        # the longer axis needs its profile time; then the settle time; polling adds at most one interval
        t_move = profile_time(40.0, 20.0, 40.0, 40.0)
        assert t_move + 0.2 <= elapsed <= t_move + 0.2 + 2 * link.poll_interval + 1e-9
    # leaving the block made the table safe: servos off
    assert not any(ax.enabled for ax in table.axes)


def test_status_decodes_everything(tcp_server, table, clock):
    clock.sleep(1.23)
    table.axes[1].alarm = 3
    with link_for(tcp_server, clock) as link:
        st = link.status()
        assert st.heartbeat == 12
        assert st.sys_flags == {"READY", "ALARM"}
        assert st.inner.alarm == "ENCODER_FAULT" and st.inner.has("ALARM")
        assert st.outer.flags == {"IN_POSITION"} and st.outer.alarm == "NONE"
        with pytest.raises(TableAlarm, match="ENCODER_FAULT"):
            link.move_to(1.0, 1.0)


def test_identity_checked(tcp_server, clock, tmp_path):
    text = default_profile_path().read_text().replace("DEVICE_ID = 0x5454", "DEVICE_ID = 0x4D42")
    (tmp_path / "other.toml").write_text(text)
    link = link_for(tcp_server, clock, profile=tmp_path / "other.toml")
    with pytest.raises(IdentityError, match="reads 0x5454.*expects 0x4D42"):
        link.connect()
    assert not link.channel.is_open


def test_rejected_while_disabled_reports_04_and_reason(server, table, clock):
    with link_for(server, clock) as link:
        with pytest.raises(MoveRejected) as err:
            link.move_to(10.0, 0.0)
        assert err.value.axis == 0 and err.value.code == 4
        assert err.value.reason == "NOT_ENABLED_OR_ESTOP"
        assert "SERVER_DEVICE_FAILURE (04)" in str(err.value) and "COMMAND" in str(err.value)
        assert (0, MOVE_ABS) not in table.commands
        assert table.commands[:2] == [(0, STOP), (1, STOP)]   # left stopped


def test_unknown_command_reports_03(tcp_server, table, clock, tmp_path):
    text = default_profile_path().read_text().replace("MOVE_ABS = 1", "MOVE_ABS = 0x7F")
    (tmp_path / "bad_cmd.toml").write_text(text)
    with link_for(tcp_server, clock, profile=tmp_path / "bad_cmd.toml") as link:
        link.enable()
        with pytest.raises(MoveRejected) as err:
            link.move_to(10.0, 0.0)
        assert err.value.code == 3 and "ILLEGAL_DATA_VALUE (03)" in str(err.value)
        assert err.value.reason == "BAD_VALUE"


def test_illegal_address_reports_02_by_name(tcp_server, clock):
    with link_for(tcp_server, clock) as link:
        with pytest.raises(ModbusExceptionError) as err:
            link.channel.write(load_profile().addr(0, "ACTUAL_POS"), [1, 2], "axis 0 ACTUAL_POS")
        assert err.value.code == 2 and err.value.name == "ILLEGAL_DATA_ADDRESS"
        assert "FC16 axis 0 ACTUAL_POS @0x0110: ILLEGAL_DATA_ADDRESS (02)" == str(err.value)
        with pytest.raises(ModbusExceptionError, match=r"FC03 .*@0x010E: ILLEGAL_DATA_ADDRESS \(02\)"):
            link.channel.read(0x010E, 2, "gap")


def test_move_that_never_arrives_times_out_stopped(server, table, clock):
    table.stall_axis = 1
    with link_for(server, clock, poll_interval=0.25) as link:
        link.enable()
        t0 = clock.now()
        with pytest.raises(MoveTimeout) as err:
            link.move_to(10.0, 30.0, speed_dps=30.0, accel_dps2=60.0)
        assert err.value.axis == 1 and "MOVING" in err.value.flags and err.value.alarm == "NONE"
        assert 14.0 < err.value.position_deg < 16.0
        expected = 1.5 * profile_time(30.0, 30.0, 60.0, 60.0) + 0.2 + 2.0 + 4 * link.poll_interval
        assert err.value.timeout_s == pytest.approx(expected)
        assert clock.now() - t0 >= expected
        assert table.commands[-2:] == [(0, STOP), (1, STOP)]
        assert not any(s.has("MOVING") for s in link.status().axes)


def test_stale_in_position_is_not_trusted(tcp_server, table, clock):
    with link_for(tcp_server, clock) as link:
        link.enable()
        link.move_to(5.0, 5.0)
        table.command_latency = 1.0      # the drive acts on the next command a second late
        t0 = clock.now()
        final = link.move_to(5.0, 5.0, settle_s=0.1)     # already there: IN_POSITION is still set
        assert clock.now() - t0 >= 1.0 + 0.1
        assert [s.cmd_seq for s in final] == [2, 2]


def test_lost_command_response_is_not_resent(server, table, clock):
    with link_for(server, clock) as link:
        link.enable()
        table.drop_command_responses = 1
        link.move_to(3.0, 4.0)
        assert table.commands == [(0, MOVE_ABS), (1, MOVE_ABS)]
        assert link.positions() == (3.0, 4.0)


def test_lost_command_request_is_resent_once(tcp_server, table, clock):
    with link_for(tcp_server, clock) as link:
        link.enable()
        table.drop_command_requests = 1
        table.drop_responses = 0
        link.move_to(3.0, 4.0)
        assert table.commands == [(0, MOVE_ABS), (1, MOVE_ABS)]


def test_reads_retry_with_backoff_then_give_up(server, table, clock):
    with link_for(server, clock, retries=2) as link:
        table.drop_responses = 2
        t0 = clock.now()
        assert link.positions() == (0.0, 0.0)
        assert clock.now() - t0 == pytest.approx(0.05 + 0.1)      # backoff through the injected clock
        table.drop_responses = 3
        with pytest.raises(CommunicationError, match="after 3 attempts"):
            link.status()
        table.drop_responses = 0
        assert link.status().outer.position_deg == 0.0             # link recovers


def test_estop_latches_until_reset(server, table, clock):
    with link_for(server, clock) as link:
        link.enable()
        link.estop()
        assert "ESTOP" in link.status().sys_flags
        with pytest.raises(EStopActive):
            link.move_to(10.0, 0.0)
        link.reset()
        link.move_to(10.0, 0.0)
        assert link.positions() == (10.0, 0.0)


def test_estop_during_move(tcp_server, table, clock):
    with link_for(tcp_server, clock) as link:
        link.enable()
        polls = []

        def hit_estop(sts):
            polls.append(sts)
            if len(polls) == 3:
                link.estop()
        with pytest.raises(EStopActive, match="e-stop latched"):
            link.move_to(90.0, 90.0, on_poll=hit_estop)
        assert len(polls) == 4
        assert 0 < link.positions()[0] < 90.0


def test_reset_reports_persisting_estop_and_alarm(tcp_server, table, clock):
    with link_for(tcp_server, clock) as link:
        link.estop()
        table.estop_held = True                 # the hard-wired e-stop button is still pressed
        with pytest.raises(EStopActive, match="still latched"):
            link.reset()
        table.estop_held = False
        table.alarm_held = 2                    # the overcurrent cause is still there
        with pytest.raises(TableAlarm, match="axis 0 \\(outer\\) ALARM_CODE=OVERCURRENT") as err:
            link.reset()
        assert err.value.axis == 0 and err.value.alarm == "OVERCURRENT"


def test_rate_mode_and_make_safe(server, table, clock):
    with link_for(server, clock) as link:
        link.enable()
        link.move_velocity("inner", -12.5, 25.0)
        clock.sleep(2.0)
        st = link.axis_status(1)
        assert st.velocity_dps == -12.5 and st.has("MOVING")
        assert table.commands[-1] == (1, MOVE_VEL)
    assert not any(ax.enabled for ax in table.axes)
    assert table.commands[-2:] == [(0, STOP), (1, STOP)]
    assert table.axes[1].track.state(clock.now())[1] == 0.0


def test_home(tcp_server, table, clock):
    with link_for(tcp_server, clock) as link:
        link.enable()
        link.move_to(30.0, -30.0)
        link.home(timeout=30.0)
        assert table.commands[-2:] == [(0, HOME), (1, HOME)]
        assert all(s.has("HOMED") for s in link.status().axes) and link.positions() == (0.0, 0.0)


def test_watchdog_register(tcp_server, clock):
    with link_for(tcp_server, clock) as link:
        link.set_watchdog(500)
        assert link.channel.read(0x0004, 1, "WATCHDOG_MS") == [500]
        with pytest.raises(ValueError, match="WATCHDOG_MS"):
            link.set_watchdog(70000)


def test_bad_move_arguments(tcp_server, table, clock):
    with link_for(tcp_server, clock) as link:
        for kwargs in ({"speed_dps": 0.0}, {"accel_dps2": -1.0}, {"tolerance_deg": float("nan")}):
            with pytest.raises(ValueError, match=next(iter(kwargs))):
                link.move_to(1.0, 1.0, **kwargs)
        with pytest.raises(ValueError, match="outer_deg"):
            link.move_to(float("inf"), 0.0)
    assert table.commands == [(0, STOP), (1, STOP)]   # only make_safe on exit


def test_connect_failure_names_the_url(clock):
    with _closed_port() as port:
        link = TurntableLink(f"tcp://127.0.0.1:{port}", clock=clock, timeout=0.1, retries=1)
        with pytest.raises(CommunicationError, match=f"127.0.0.1:{port}"):
            link.connect()


class _closed_port:
    def __enter__(self) -> int:
        import socket
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        return self.sock.getsockname()[1]

    def __exit__(self, *exc) -> None:
        self.sock.close()


def test_with_block_makes_safe_after_an_error(tcp_server, table, clock):
    with pytest.raises(RuntimeError, match="procedure bug"):
        with link_for(tcp_server, clock) as link:
            link.enable()
            link.move_velocity("outer", 15.0, 30.0)
            raise RuntimeError("procedure bug")
    assert table.commands[-2:] == [(0, STOP), (1, STOP)]
    assert not any(ax.enabled for ax in table.axes)
    assert table.axes[0].track.state(clock.now())[1] == 0.0


def test_make_safe_never_raises_on_a_dead_link(tcp_server, table, clock, caplog):
    link = link_for(tcp_server, clock, retries=1).connect()
    link.enable()
    table.drop_responses = 1000
    link.make_safe()
    assert "link down" in caplog.text
    table.drop_responses = 0
    assert link.axis_status(0).has("ENABLED")     # it really did not get through
    link.close()
