"""Debian's mbpoll (libmodbus) reads the fake chamber's process value as an F4T float (low word first)."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from fixtures.chamber import ChamberServer, FakeChamber
from rig.clock import SimClock

MBPOLL = shutil.which("mbpoll")


def test_mbpoll_reads_the_process_value_and_writes_the_set_point():
    assert MBPOLL, "mbpoll is required (apt-get install -y mbpoll)"
    clock = SimClock()
    chamber = FakeChamber(clock)
    with ChamberServer(chamber) as server:
        base = [MBPOLL, "-m", "tcp", "-p", str(server.port), "-a", "1", "-0", "-1", "-q", "-t", "4:float"]
        wrote = subprocess.run([*base, "-r", "2782", "127.0.0.1", "--", "41.5"], capture_output=True, text=True,
                               timeout=10)
        assert wrote.returncode == 0, wrote.stderr
        assert chamber.state.set_point == pytest.approx(41.5)
        read = subprocess.run([*base, "-r", "27586", "127.0.0.1"], capture_output=True, text=True, timeout=10)
        assert read.returncode == 0, read.stderr
        values = [float(line.split(":")[1]) for line in read.stdout.splitlines() if line.startswith("[")]
        assert values == [pytest.approx(chamber.temperatures()[0], abs=1e-4)]
