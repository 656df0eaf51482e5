"""TurntableLink against the project's fake turntable (fixtures.turntable), a real pymodbus server."""

from __future__ import annotations

import pytest

from fixtures.turntable import FakeTurntable, TurntableServer
from holding_gateway import HoldingGateway
from rig.clock import SimClock
from rig.turntable import (EStopActive, ModbusExceptionError, MoveRejected, MoveTimeout, TableAlarm,
                           TurntableLink, load_profile, profile_time)

PROFILE = load_profile()


@pytest.fixture
def clock() -> SimClock:
    return SimClock()


@pytest.fixture
def fake(clock) -> FakeTurntable:
    return FakeTurntable(clock=clock)


def link_to(url: str, clock, **kw) -> TurntableLink:
    kw.setdefault("timeout", 0.1)
    return TurntableLink(url, clock=clock, **kw)


@pytest.mark.parametrize("transport", ["tcp", "rtu-tcp", "rtu-pty"])
def test_full_move_protocol(transport, fake, clock):
    with TurntableServer(fake, transport=transport) as srv, link_to(srv.url, clock) as link:
        assert link.identify() == (0x5454, 0x0100)
        link.enable()
        t0 = clock.now()
        final = link.move_to(35.0, -70.0, speed_dps=40.0, accel_dps2=80.0, tolerance_deg=0.005)
        assert [s.cmd_seq for s in final] == [1, 1]
        assert final[0].position_deg == pytest.approx(35.0, abs=0.005)
        assert final[1].position_deg == pytest.approx(-70.0, abs=0.005)
        assert clock.now() - t0 >= profile_time(70.0, 40.0, 80.0, 80.0) + 0.2
        assert fake.encoder_angles(clock.now()) == pytest.approx([35.0, -70.0], abs=0.005)
        assert link.positions() == pytest.approx((35.0, -70.0), abs=0.001)
    status = fake.registers()
    assert status[0x0100] == 0 and status[0x0200] == 0          # make_safe disabled both servos


def test_status_heartbeat_and_flags(fake, clock):
    with TurntableServer(fake) as srv, link_to(srv.url, clock) as link:
        link.enable()
        hb = link.status().heartbeat
        clock.sleep(1.0)
        st = link.status()
        assert st.heartbeat - hb == 10 and "READY" in st.sys_flags
        assert st.outer.has("ENABLED") and not st.outer.has("MOVING")


def test_move_that_never_arrives_times_out_with_table_stopped(fake, clock):
    fake.faults.never_arrive(axis=1, short_by_deg=0.5)
    with TurntableServer(fake, transport="rtu-tcp") as srv, link_to(srv.url, clock, poll_interval=0.25) as link:
        link.enable()
        with pytest.raises(MoveTimeout) as err:
            link.move_to(10.0, 20.0)
        assert err.value.axis == 1 and err.value.axis_name == "inner"
        assert err.value.position_deg == pytest.approx(19.5, abs=0.01)
        assert "IN_POSITION" not in err.value.flags
        st = link.status()
        assert not any(a.has("MOVING") for a in st.axes)
        assert [a.cmd_seq for a in st.axes] == [2, 2]      # MOVE_ABS, then the STOP the client sent


@pytest.mark.parametrize("deliver_after", [6, None])
def test_stale_in_position_from_previous_move_is_not_trusted(fake, clock, deliver_after):
    with TurntableServer(fake) as srv:
        gateway = HoldingGateway(("127.0.0.1", srv.port), clock)
        try:
            with link_to(gateway.url, clock) as link:
                link.enable()
                link.move_to(5.0, 5.0)
                assert link.axis_status(0).has("IN_POSITION")
                gateway.hold(PROFILE.addr(0, "COMMAND"), deliver_after)
                if deliver_after is None:
                    with pytest.raises(MoveTimeout, match="axis 0 .*CMD_SEQ advance"):
                        link.move_to(5.0, 5.0, settle_s=0.1)
                    return
                final = link.move_to(5.0, 5.0, settle_s=0.1)
                assert gateway.delivered_at is not None and gateway.delivered_at > gateway.held_at
                assert clock.now() >= gateway.delivered_at + 0.1
                assert final[0].cmd_seq == 2
        finally:
            gateway.close()


@pytest.mark.parametrize("transport", ["tcp", "rtu-tcp"])
def test_exceptions_02_03_04_by_name(transport, fake, clock):
    with TurntableServer(fake, transport=transport) as srv, link_to(srv.url, clock) as link:
        with pytest.raises(MoveRejected) as e04:
            link.move_to(10.0, 0.0)                                   # servos off
        assert e04.value.code == 4 and e04.value.reason == "NOT_ENABLED_OR_ESTOP"
        assert "SERVER_DEVICE_FAILURE (04)" in str(e04.value)
        link.enable()
        with pytest.raises(MoveRejected) as e03:
            link.move_to(0.0, 400.0)                                  # beyond the +360 deg soft limit
        assert e03.value.axis == 1 and e03.value.code == 3 and e03.value.reason == "OUT_OF_LIMITS"
        assert "ILLEGAL_DATA_VALUE (03)" in str(e03.value)
        with pytest.raises(ModbusExceptionError) as e02:
            link.channel.write(PROFILE.addr(1, "CMD_SEQ"), [0], "axis 1 CMD_SEQ")
        assert str(e02.value) == "FC06 axis 1 CMD_SEQ @0x021B: ILLEGAL_DATA_ADDRESS (02)"
        assert not any(a.has("MOVING") for a in link.status().axes)


def test_refused_move_leaves_table_stopped(fake, clock):
    with TurntableServer(fake) as srv, link_to(srv.url, clock) as link:
        link.enable()
        link.move_velocity(0, 20.0, 40.0)
        fake.faults.refuse_moves(axis=1)
        with pytest.raises(MoveRejected) as err:
            link.move_to(50.0, 50.0)
        assert err.value.axis == 1
        clock.sleep(2.0)
        assert link.axis_status(0).velocity_dps == 0.0


def test_estop_button_during_move_then_reset(fake, clock):
    with TurntableServer(fake) as srv, link_to(srv.url, clock) as link:
        link.enable()
        polls = []

        def press_button(sts):
            polls.append(sts[0].position_deg)
            if len(polls) == 5:
                fake.faults.trigger_estop()
        with pytest.raises(EStopActive):
            link.move_to(90.0, 0.0, on_poll=press_button)
        assert len(polls) == 6 and 0 < polls[-1] < 90.0
        with pytest.raises(EStopActive):
            link.enable()
        link.reset()
        link.enable()
        link.move_to(1.0, 1.0)
        assert link.positions() == pytest.approx((1.0, 1.0), abs=0.001)


def test_software_estop_and_alarm(fake, clock):
    with TurntableServer(fake) as srv, link_to(srv.url, clock) as link:
        link.enable()
        link.estop()
        assert "ESTOP" in link.status().sys_flags
        with pytest.raises(EStopActive):
            link.move_to(1.0, 1.0)
        link.reset()
        link.enable()
        fake.faults.raise_alarm(0, code=2)
        with pytest.raises(TableAlarm, match="OVERCURRENT") as err:
            link.move_to(1.0, 1.0)
        assert err.value.axis == 0


def test_lost_replies_never_execute_a_command_twice(fake, clock):
    fake.faults.drop_randomly(0.15, seed=7)
    with TurntableServer(fake) as srv, link_to(srv.url, clock, timeout=0.03, retries=5) as link:
        link.enable()
        targets = [(10.0, -10.0), (20.0, 5.0), (-5.0, 15.0), (0.0, 0.0)]
        for outer, inner in targets:
            link.move_to(outer, inner)
        assert fake.faults.dropped >= 5
        fake.faults.clear()
        assert [a.cmd_seq for a in link.status().axes] == [len(targets)] * 2
        assert link.positions() == pytest.approx((0.0, 0.0), abs=0.001)


def test_watchdog_trips_when_the_client_goes_quiet(fake, clock):
    with TurntableServer(fake) as srv, link_to(srv.url, clock) as link:
        link.enable()
        link.set_watchdog(300)
        link.move_velocity("outer", 10.0, 20.0)
        clock.sleep(1.0)
        st = link.status()
        assert "WATCHDOG" in st.sys_flags and st.outer.alarm == "COMMS_WATCHDOG"
        assert st.outer.velocity_dps == 0.0
        link.set_watchdog(0)
        link.reset()
        assert link.status().outer.alarm == "NONE"


def test_home(fake, clock):
    with TurntableServer(fake) as srv, link_to(srv.url, clock) as link:
        link.enable()
        link.move_to(12.0, -8.0, speed_dps=60.0, accel_dps2=120.0)
        t0 = clock.now()
        link.home(timeout=30.0, speed_dps=6.0, accel_dps2=12.0)
        t_home = profile_time(12.0, 6.0, 12.0, 12.0)
        assert t_home <= clock.now() - t0 <= t_home + 0.2
        st = link.status()
        assert all(a.has("HOMED") and not a.has("HOMING") for a in st.axes)
        assert link.positions() == pytest.approx((0.0, 0.0), abs=0.001)


def test_a_100s_simulated_move_waits_on_the_simulated_clock_and_polls_sparingly():
    """With a simulated clock the client's waits advance that clock, not the wall's; polls are spaced while arrival
    is far off (at most half the time left, up to 0.5 s), so a 100 s move is not polled every poll_interval."""
    from fixtures.turntable import FakeTurntable, TurntableServer
    from rig.clock import SimClock
    from rig.turntable import TurntableLink

    clock = SimClock()
    tt = FakeTurntable(clock, soft_limits=((-4000.0, 4000.0), (-4000.0, 4000.0)))
    with TurntableServer(tt) as srv, TurntableLink(srv.url, clock=clock) as link:
        link.enable()
        requests, start = link.channel.requests, clock.now()
        link.move_to(3000.0, 0.0, speed_dps=30.0, accel_dps2=60.0)
        took = clock.now() - start
        assert took > 100.0
        assert link.positions()[0] == pytest.approx(3000.0, abs=0.01)
        every_poll_interval = len(link.axes) * took / link.poll_interval
        assert link.channel.requests - requests < every_poll_interval / 4, link.channel.requests - requests
