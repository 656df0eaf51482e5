"""Our client against the fake chamber over Modbus TCP, RTU framing over TCP and RTU on a pty pair."""

from __future__ import annotations

import pytest

from fixtures.chamber import ChamberServer, FakeChamber
from rig.chamber import ChamberError, ChamberLink, IdentityError, ModbusExceptionError
from rig.clock import SimClock
from rig.modbus.errors import LinkError


@pytest.mark.parametrize("transport", ["tcp", "rtu-tcp", "rtu-pty"])
def test_set_ramp_run_wait_and_leave_safe_on_every_transport(transport):
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber, transport) as server:
        with ChamberLink(server.url, clock=clock, timeout=1.0) as link:
            link.ramp_rate(4.0)
            link.set_point(-10.0)
            link.run()
            st = link.status()
            assert (st.set_point_c, st.ramp_c_per_min, st.running, st.alarm) == (-10.0, 4.0, True, "")
            air = link.wait_air(-10.0, 0.3, timeout=3600.0, settle_s=30.0)
            assert abs(air + 10.0) <= 0.3
            assert link.air_c() == pytest.approx(chamber.temperatures()[0], abs=1e-4)   # single precision
        assert not chamber.state.running, "leaving the with block stops the chamber"
        assert chamber.state.set_point == pytest.approx(chamber.profile.ambient_c)


def test_a_controller_showing_fahrenheit_is_read_and_written_in_celsius():
    clock = SimClock()
    chamber = FakeChamber(clock, display_units="F")
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock) as link:
        assert link.fahrenheit
        assert link.air_c() == pytest.approx(23.0, abs=1e-4)
        link.ramp_rate(2.0)
        link.set_point(50.0)
        assert chamber.state.set_point == pytest.approx(50.0, abs=1e-4)
        assert chamber.ramp_rate_units == pytest.approx(3.6, abs=1e-5), "2 C/min is 3.6 F/min on the wire"
        assert link.status().ramp_c_per_min == pytest.approx(2.0, abs=1e-5)


def test_an_exception_reply_is_named_and_limits_are_refused_before_writing():
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock) as link:
        chamber.faults.reply_exception(4, address=2782, times=1)
        with pytest.raises(ChamberError, match=r"SET_POINT=40.0 refused: FC16 SET_POINT @0x0ADE: "
                                               r"SERVER_DEVICE_FAILURE \(04\)") as info:
            link.set_point(40.0)
        assert isinstance(info.value.__cause__, ModbusExceptionError)
        assert isinstance(info.value.__cause__, LinkError)
        with pytest.raises(ValueError, match="outside the chamber's limits -70..180 C"):
            link.set_point(250.0)
        with pytest.raises(ValueError, match="ramp rate"):
            link.ramp_rate(-1.0)
        assert chamber.state.set_point == pytest.approx(23.0)


def test_a_device_that_is_not_an_f4t_or_reports_failure_is_refused():
    clock = SimClock()
    chamber = FakeChamber(clock)
    chamber.words["DEVICE_STATUS"] = 32
    with ChamberServer(chamber) as server:
        with pytest.raises(IdentityError, match="DEVICE_STATUS reads FAIL"):
            ChamberLink(server.url, clock=clock).connect()
        chamber.faults.reply_exception(2, address=90)
        with pytest.raises(IdentityError, match="ILLEGAL_DATA_ADDRESS"):
            ChamberLink(server.url, clock=clock).connect()


def test_stop_switches_the_conditioning_off_even_when_the_set_point_is_refused():
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server:
        link = ChamberLink(server.url, clock=clock).connect()
        link.set_point(70.0)
        link.run()
        chamber.faults.reply_exception(4, address=2782)
        with pytest.raises(ChamberError, match="SET_POINT=23.0 refused"):
            link.stop()
        link.close()
    assert not chamber.state.running and chamber.state.set_point == pytest.approx(70.0)
