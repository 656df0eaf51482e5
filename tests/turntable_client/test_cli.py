"""`rig table ...` against the fake turntable on real time (short moves only)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from click.testing import CliRunner

from fixtures.turntable import FakeTurntable, TurntableServer
from rig.cli import main
from rig.clock import RealClock


def run(url: str, *args: str):
    return CliRunner().invoke(main, ["table", "--url", url, "--timeout", "0.5", *args])


def test_status_move_stop_estop_reset():
    fake = FakeTurntable(clock=RealClock())
    with TurntableServer(fake) as srv:
        out = run(srv.url, "status")
        assert out.exit_code == 0, out.output
        assert "DEVICE_ID=0x5454 MAP_VERSION=0x0100 (tt-map/1)" in out.output
        assert "axis 1 (inner): +0.0000 deg" in out.output
        out = run(srv.url, "move", "--speed", "60", "--accel", "600", "--", "0.5", "-0.25")
        assert out.exit_code == 0, out.output
        assert "outer +0.5000 deg, inner -0.2500 deg" in out.output
        assert fake.encoder_angles(fake.clock.now()) == pytest.approx([0.5, -0.25], abs=0.002)
        assert "STATUS={ENABLED, IN_POSITION}" in run(srv.url, "status").output   # servos hold position
        assert run(srv.url, "stop").exit_code == 0
        assert run(srv.url, "estop").output.strip() == "e-stop latched"
        out = run(srv.url, "move", "1", "1")
        assert out.exit_code == 3 and "e-stop latched" in out.output          # rig.exits.EXIT_TABLE
        assert f"rig table --url {srv.url} reset" in out.output and "reset()" not in out.output
        assert run(srv.url, "reset").exit_code == 0
        assert run(srv.url, "disable").exit_code == 0
        assert "ENABLED" not in run(srv.url, "status").output.split("axis 0")[1]


def test_errors_exit_non_zero_with_message(tmp_path):
    out = run("udp://127.0.0.1:502", "status")
    assert out.exit_code == 2 and "scheme 'udp'" in out.output
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n')
    out = CliRunner().invoke(main, ["table", "--url", "tcp://127.0.0.1:1", "--profile", str(bad), "status"])
    assert out.exit_code == 2 and "bad.toml" in out.output and "'word_order'" in out.output
    fake = FakeTurntable(clock=RealClock())
    with TurntableServer(fake) as srv:
        out = run(srv.url, "move", "0", "500")
        assert out.exit_code == 2 and "OUT_OF_LIMITS" in out.output and "ILLEGAL_DATA_VALUE (03)" in out.output


def test_a_missing_serial_device_is_named_at_once(tmp_path):
    """rtu:// to a device that does not exist: one line naming it, no retries, no pymodbus chatter."""
    device = tmp_path / "ttyUSB9"
    done = subprocess.run([sys.executable, "-m", "rig.cli", "table", "--url", f"rtu://{device}", "status"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 3
    assert f"no such device {device}" in done.stderr
    assert "attempts" not in done.stderr and "retry" not in done.stderr and "Repeating" not in done.stderr
    assert "Traceback" not in done.stderr


def test_a_refused_connection_names_the_cause(tmp_path):
    import socket

    with socket.socket() as s:          # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    done = subprocess.run([sys.executable, "-m", "rig.cli", "table", "--url", f"tcp://127.0.0.1:{port}", "status"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 3
    assert f"tcp://127.0.0.1:{port}: Connection refused" in done.stderr
    assert "Repeating" not in done.stderr and "Traceback" not in done.stderr
