"""Faults: a controller that stops answering (for a while, for good), a set point never reached, an alarm;
each a named error, and through `rig chamber` its exit code (rig/exits.py) with no traceback."""

from __future__ import annotations

import logging

import pytest
from click.testing import CliRunner

from fixtures.chamber import ChamberServer, FakeChamber
from rig.chamber import ChamberAlarm, ChamberLink, CommunicationError, SetPointNotReached
from rig.cli import main
from rig.clock import RealClock, SimClock
from rig.exits import Exit
from rig.locks import chamber_lock
from rig.modbus.errors import CommunicationError as LinkCommunicationError


@pytest.fixture(autouse=True)
def _quiet_pymodbus():
    logger = logging.getLogger("pymodbus")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    yield
    logger.setLevel(level)


@pytest.fixture(autouse=True)
def _private_locks(tmp_path, monkeypatch):
    monkeypatch.setenv("RIG_LOCK_DIR", str(tmp_path / "locks"))


def cli(url: str, *args: str):
    return CliRunner().invoke(main, ["chamber", "--url", url, "--timeout", "0.2", *args])


def test_a_controller_silent_for_a_while_is_ridden_out_by_the_retries():
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock, timeout=0.2, retries=3) as link:
        chamber.faults.stop_answering(for_s=0.1)          # the first backoffs (0.05 + 0.1 s) outlast it
        assert link.air_c() == pytest.approx(23.0, abs=1e-4)
        assert chamber.faults.dropped >= 1 and link.channel.failures >= 1


def test_a_controller_that_stops_answering_is_a_named_error_and_exit_3():
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server:
        link = ChamberLink(server.url, clock=clock, timeout=0.2, retries=1).connect()
        try:
            chamber.faults.stop_answering()
            with pytest.raises(CommunicationError, match=r"PROCESS_VALUE @0x6BC2 on tcp://.*no valid response "
                                                         r"after 2 attempts") as info:
                link.air_c()
            assert isinstance(info.value, LinkCommunicationError)
        finally:
            link.close()
        out = cli(server.url, "status")
        assert out.exit_code == Exit.FAILED == 3, out.output
        assert "no valid response" in out.output and "Traceback" not in out.output


def test_a_set_point_the_chamber_cannot_reach_is_a_named_error_and_exit_3():
    clock = SimClock()
    chamber = FakeChamber(clock)
    chamber.limit_power(max_air_c=40.0)
    with ChamberServer(chamber) as server:
        with ChamberLink(server.url, clock=clock) as link:
            link.set_point(60.0)
            link.run()
            with pytest.raises(SetPointNotReached, match=r"did not reach 60.00 C \(\+-0.5 C\) within 1800 s: "
                                                         r"at 40.00 C") as info:
                link.wait_air(60.0, 0.5, timeout=1800.0)
            assert info.value.air_c == pytest.approx(40.0, abs=0.01)

    real = FakeChamber(RealClock())
    real.limit_power(max_air_c=23.5)
    with ChamberServer(real) as server:
        out = cli(server.url, "set", "--c", "30", "--wait", "--soak-timeout", "0.5")
        assert out.exit_code == 3, out.output
        assert "did not reach 30.00 C" in out.output and "Traceback" not in out.output
        assert not real.state.running, "a failed `set` leaves the chamber safe"
        assert real.state.set_point == pytest.approx(23.0)


def test_an_alarm_ends_a_wait_by_name():
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server, ChamberLink(server.url, clock=clock) as link:
        link.set_point(80.0)
        link.run()
        chamber.raise_alarm(7)
        with pytest.raises(ChamberAlarm, match="alarm 1 state 7"):
            link.wait_air(80.0, 0.5, timeout=3600.0)
        assert "ALARM alarm 1 state 7" in link.status().describe()


def test_cli_status_set_stop_against_a_served_chamber_and_the_lock():
    chamber = FakeChamber(RealClock())
    with ChamberServer(chamber) as server:
        out = cli(server.url, "set", "--c", "35", "--ramp", "1.5")
        assert out.exit_code == 0, out.output
        assert chamber.state.running and chamber.state.set_point == pytest.approx(35.0)
        out = cli(server.url, "status")
        assert out.exit_code == 0 and "set point 35.00 C" in out.output and "ramp 1.5 C/min" in out.output
        assert cli(server.url, "set", "--c", "999").exit_code == Exit.BAD_INPUT
        out = cli(server.url, "stop")
        assert out.exit_code == 0, out.output
        assert not chamber.state.running and chamber.state.set_point == pytest.approx(23.0)


def test_a_chamber_held_by_another_command_is_busy_but_can_always_be_stopped():
    chamber = FakeChamber(RealClock())
    with ChamberServer(chamber) as server, chamber_lock(server.url):
        out = cli(server.url, "set", "--c", "30")
        assert out.exit_code == Exit.BUSY == 4, out.output
        assert "chamber 127.0.0.1:" in out.output and not chamber.state.running
        assert cli(server.url, "stop").exit_code == 0
        assert cli(server.url, "status").exit_code == 0
