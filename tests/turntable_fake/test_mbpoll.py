"""A third-party client (Debian's mbpoll, libmodbus) drives the fake on a time-scaled real clock."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time

import pytest

from fixtures.turntable import FakeTurntable, TurntableServer
from fixtures.turntable.cli import ScaledClock

MBPOLL = shutil.which("mbpoll")


def mbpoll(args: list[str], values: list[int] | None = None) -> subprocess.CompletedProcess:
    assert MBPOLL, "mbpoll is required (apt-get install -y mbpoll)"
    cmd = [MBPOLL, "-a", "1", "-0", "-1", "-q", *args]
    if values is not None:
        cmd += ["--", *map(str, values)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=10)


def read_values(out: str) -> list[int]:
    return [int(line.split(":")[1]) for line in out.splitlines() if line.startswith("[")]


def tcp_args(port: int, *more: str) -> list[str]:
    return ["-m", "tcp", "-p", str(port), *more, "127.0.0.1"]


def test_mbpoll_reads_identity_and_drives_a_move_over_tcp():
    tt = FakeTurntable(ScaledClock(20.0), settle_s=0.1)
    with TurntableServer(tt) as srv:
        p = srv.port
        r = mbpoll(tcp_args(p, "-r", "0", "-c", "2"))
        assert r.returncode == 0, r.stderr
        assert read_values(r.stdout) == [0x5454, 0x0100]
        assert mbpoll(tcp_args(p, "-r", "0x104", "-t", "4:int", "-B"), [90_000, 180_000]).returncode == 0
        assert mbpoll(tcp_args(p, "-r", "0x100"), [1]).returncode == 0
        assert mbpoll(tcp_args(p, "-r", "0x102", "-t", "4:int", "-B"), [-45_000]).returncode == 0
        assert mbpoll(tcp_args(p, "-r", "0x101"), [1]).returncode == 0
        deadline = time.monotonic() + 5.0
        while True:
            status, _, _, seq = read_values(mbpoll(tcp_args(p, "-r", "0x118", "-c", "4")).stdout)
            if status & 4 or time.monotonic() > deadline:
                break
            time.sleep(0.02)
        pos = read_values(mbpoll(tcp_args(p, "-r", "0x110", "-t", "4:int", "-B")).stdout)[0]
        assert (pos, status & 0b111, seq) == (-45_000, 0b101, 1), "arrived, enabled, in position"
        bad = mbpoll(tcp_args(p, "-r", "0x110"), [5])
        assert bad.returncode == 1 and "Illegal data address" in bad.stderr + bad.stdout


def test_mbpoll_over_rtu_on_the_pty_pair():
    tt = FakeTurntable(ScaledClock(1.0), start_angles=(12.5, 0.0))
    with TurntableServer(tt, transport="rtu-pty") as srv:
        r = mbpoll(["-m", "rtu", "-b", "115200", "-P", "none", "-r", "0x110", "-t", "4:int", "-B",
                    srv.client_port])
        assert r.returncode == 0, r.stderr
        assert read_values(r.stdout) == [12_500]
        r = mbpoll(["-m", "rtu", "-b", "115200", "-P", "none", "-r", "0x101", srv.client_port], [0x42])
        assert r.returncode == 1 and "Illegal data value" in r.stderr + r.stdout


@pytest.mark.parametrize("stop, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_cli_serves_until_stopped_and_exits_as_every_command_stopped_by_a_signal(stop, code):
    proc = subprocess.Popen([sys.executable, "-u", "-m", "rig.cli", "sim-turntable", "--port", "0",
                             "--time-scale", "5"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert "tcp://127.0.0.1:" in line, line + proc.stderr.read()
        port = int(line.split("tcp://127.0.0.1:")[1].split()[0])
        r = mbpoll(tcp_args(port, "-r", "0"))
        assert read_values(r.stdout) == [0x5454]
        proc.send_signal(stop)
        assert proc.wait(10) == code
        err = proc.stderr.read()
        assert "Traceback" not in err and err.strip().count("\n") == 0, err
    finally:
        if proc.poll() is None:
            proc.kill()


def test_cli_refuses_remote_hosts():
    refused = subprocess.run([sys.executable, "-m", "rig.cli", "sim-turntable", "--host", "192.0.2.1"],
                             capture_output=True, text=True, timeout=30)
    assert refused.returncode == 2 and "--allow-remote" in refused.stderr


@pytest.mark.parametrize("scale", [0.0, -1.0])
def test_scaled_clock_rejects_nonpositive_scale(scale):
    with pytest.raises(ValueError):
        ScaledClock(scale)
