"""The fake serves any register profile the client reads: a user's own map runs under --sim."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from fixtures.turntable import FakeTurntable, TurntableServer
from fixtures.turntable.cli import ScaledClock
from rig.clock import SimClock
from rig.turntable import TurntableLink, load_profile

# A drive-style map: other addresses, centidegrees, low word first, another device id and identity,
# other status bit numbers and command values, and LAST_ERROR named differently.
PLC_PROFILE = """
name = "plc-map/2"
device_id = 7
word_order = "little"
units_per_degree = 100

[identity]
DEVICE_ID = 0x1234
MAP_VERSION = 0x0200

[global]
DEVICE_ID = 0x0010
MAP_VERSION = 0x0011
SYS_STATUS = 0x0012
HEARTBEAT = 0x0013
WATCHDOG_MS = 0x0014
SYS_COMMAND = 0x0015

[axes]
bases = [0x1000, 0x1040]
names = ["tilt", "spin"]

[axis_registers]
ACTUAL_POS = 0x00
ACTUAL_VEL = 0x02
ENCODER_COUNTS = 0x04
FOLLOWING_ERR = 0x06
STATUS = 0x08
ALARM_CODE = 0x09
LAST_ERROR = 0x0A
CMD_SEQ = 0x0B
ENABLE = 0x20
COMMAND = 0x21
TARGET_POS = 0x22
TARGET_VEL = 0x24
ACCEL = 0x26
DECEL = 0x28
SOFT_LIMIT_POS = 0x2A
SOFT_LIMIT_NEG = 0x2C

[sys_status_bits]
READY = 15
ESTOP = 14
ALARM = 13
WATCHDOG = 12

[status_bits]
ENABLED = 8
MOVING = 9
IN_POSITION = 10
HOMED = 11
HOMING = 12
ALARM = 13
ESTOP = 14
CMD_REJECTED = 15

[commands]
MOVE_ABS = 0x11
MOVE_VEL = 0x13
STOP = 0x14
HOME = 0x15
ALARM_RESET = 0x20

[sys_commands]
ESTOP = 0xE5
RESET = 0xAA

[alarm_codes]
NONE = 0
COMMS_WATCHDOG = 40
OVERCURRENT = 41

[last_errors]
NONE = 0
NOT_READY = 9
OUT_OF_LIMITS = 10
BAD_VALUE = 11
"""


@pytest.fixture
def plc_profile(tmp_path) -> Path:
    path = tmp_path / "plc.toml"
    path.write_text(PLC_PROFILE)
    return path


def test_client_and_fake_agree_on_a_users_map_through_moves(plc_profile):
    clock = SimClock()
    fake = FakeTurntable(clock, profile=plc_profile, soft_limits=((-200, 200), (-200, 200)))
    with TurntableServer(fake) as srv, TurntableLink(srv.url, profile=plc_profile, clock=clock, timeout=1.0) as link:
        link.enable()
        for outer, inner in ((30.0, -45.5), (-120.25, 170.0), (0.0, 0.0)):
            link.move_to(outer, inner, speed_dps=60.0, accel_dps2=120.0, tolerance_deg=0.01, settle_s=0.1)
            assert np.allclose(link.positions(), (outer, inner), atol=0.011)
            assert np.allclose(fake.encoder_angles(clock.now()), (outer, inner), atol=0.01)
        status = link.axis_status(1)
        assert {"IN_POSITION", "ENABLED"} <= status.flags
        assert fake.image[0x1040 + 0x0B] == status.cmd_seq >= 3, "spin CMD_SEQ at the profile's address"


def test_a_rejected_command_reads_back_the_profiles_codes(plc_profile):
    clock = SimClock()
    fake = FakeTurntable(clock, profile=plc_profile)
    assert fake.handle_request(6, 0x1021, 1, [0x11]) != [0x11], "MOVE_ABS while disabled is refused"
    fake.handle_request(3, 0x1000, 12, None)
    assert fake.image[0x100A] == 9, "LAST_ERROR: the profile's NOT_READY"
    assert fake.image[0x1008] & (1 << 15), "STATUS: the profile's CMD_REJECTED bit"
    assert fake.handle_request(6, 0x1021, 1, [1]) != [1], "tt-map/1's MOVE_ABS value is no command here"
    assert fake.handle_request(3, 0x0100, 1, None) != [0], "tt-map/1's addresses are not this map's"


def test_the_tt_map_addresses_still_answer_as_the_spec_says():
    fake = FakeTurntable(SimClock())
    assert fake.handle_request(3, 0x0000, 2, None) == [0x5454, 0x0100]
    assert fake.map.profile.name == "tt-map/1"


def test_mbpoll_reads_a_users_map_at_its_addresses(plc_profile):
    assert shutil.which("mbpoll"), "mbpoll is required (scripts/test.sh installs Debian's mbpoll)"
    fake = FakeTurntable(ScaledClock(1.0), profile=plc_profile, start_angles=(12.5, -3.0))
    with TurntableServer(fake) as srv:
        ident = subprocess.run(["mbpoll", "-a", "7", "-0", "-1", "-q", "-m", "tcp", "-p", str(srv.port), "-r", "0x10",
                                "-c", "2", "127.0.0.1"], capture_output=True, text=True, timeout=10)
        assert ident.returncode == 0, ident.stderr
        assert [int(line.split(":")[1]) for line in ident.stdout.splitlines() if line.startswith("[")] == [0x1234, 0x200]
        pos = subprocess.run(["mbpoll", "-a", "7", "-0", "-1", "-q", "-m", "tcp", "-p", str(srv.port), "-r", "0x1000",
                              "-t", "4:int", "127.0.0.1"], capture_output=True, text=True, timeout=10)
        assert pos.returncode == 0, pos.stderr
        assert [int(line.split(":")[1]) for line in pos.stdout.splitlines() if line.startswith("[")] == [1250], \
            "12.5 deg in centidegrees, low word first"


def test_a_simulated_session_runs_on_a_users_profile(plc_profile, tmp_path):
    config = tmp_path / "rig.toml"
    text = resources.files("rig.configs").joinpath("sim.toml").read_text()
    assert "[turntable]" in text
    config.write_text(text.replace("[turntable]", '[turntable]\nprofile = "plc.toml"', 1))
    out = tmp_path / "session"
    done = subprocess.run([sys.executable, "-m", "rig.cli", "calibrate", "--sim", "--config", str(config),
                           "--orientations", "9", "--no-progress", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    cal = json.loads((out / "calibration.json").read_text())["sensors"]
    truth = json.loads((out / "truth.json").read_text())["sensors"]
    H, Ht = np.array(cal["gyro"]["H"]), np.array(truth["gyro"]["H"])
    assert np.linalg.norm(H - Ht) / np.linalg.norm(Ht) < 2e-3


def test_sim_turntable_serves_a_profile_and_refuses_a_broken_one(plc_profile, tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text(PLC_PROFILE.replace('word_order = "little"', 'word_order = "middle"'))
    done = subprocess.run([sys.executable, "-m", "rig.cli", "sim-turntable", "--port", "0", "--profile", str(broken)],
                          capture_output=True, text=True, timeout=30)
    assert done.returncode != 0 and "word_order" in done.stderr and "Traceback" not in done.stderr
    assert load_profile(plc_profile).name == "plc-map/2"
