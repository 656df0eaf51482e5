"""Inputs checked at the command line, one clear message per mistake, and every command taking the session
folder as the rig writes it."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from rig.exits import plain

RIG = [sys.executable, "-m", "rig.cli"]


def rig(*args, **kw):
    return subprocess.run([*RIG, *args], capture_output=True, text=True, timeout=300, **kw)


def clean(res, code):
    assert res.returncode == code, res.stdout + res.stderr
    assert "Traceback" not in res.stdout + res.stderr
    assert "np.float64" not in res.stdout + res.stderr


@pytest.fixture(scope="module")
def rig_session(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "unit"
    clean(rig("calibrate", "--sim", "--orientations", "9", "--no-progress", "--out", str(out)), 0)
    return out


def test_the_table_takes_negative_angles_as_typed():
    from fixtures.turntable import FakeTurntable, TurntableServer
    from rig.clock import RealClock

    fake = FakeTurntable(clock=RealClock())
    with TurntableServer(fake) as srv:
        res = rig("table", "--url", srv.url, "move", "0.5", "-0.25", "--speed", "60", "--accel", "600")
        clean(res, 0)
        assert "outer +0.5000 deg, inner -0.2500 deg" in res.stdout
        res = rig("table", "--url", srv.url, "move", "--speed", "60", "-0.5", "-1")
        clean(res, 0)
        assert "outer -0.5000 deg, inner -1.0000 deg" in res.stdout
        clean(rig("table", "--url", srv.url, "move", "nan", "1"), 2)
        clean(rig("table", "--url", srv.url, "disable"), 0)


@pytest.mark.parametrize("value", ["nan", "inf", "0", "-2"])
def test_the_fake_turntable_refuses_a_time_scale_that_is_no_speed(value):
    res = rig("sim-turntable", "--time-scale", value)
    clean(res, 2)
    assert "--time-scale" in res.stderr


def test_a_taken_port_for_the_fake_turntable_is_named():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = rig("sim-turntable", "--port", str(port))
    clean(res, 4)                                       # busy: another process holds it, named
    assert f"127.0.0.1:{port}" in res.stderr and f"in use by pid {os.getpid()}" in res.stderr


def test_export_does_not_overwrite_without_force(rig_session, tmp_path):
    clean(rig("export", str(rig_session), "--to", str(tmp_path / "x")), 0)
    again = rig("export", str(rig_session), "--to", str(tmp_path / "x"))
    clean(again, 2)
    assert "--force" in again.stderr and "meta.json" in again.stderr
    clean(rig("export", str(rig_session), "--to", str(tmp_path / "x"), "--force"), 0)


def test_commands_take_the_rig_session_folder_and_name_what_is_not_one(rig_session, tmp_path):
    res = rig("discrepancy", str(rig_session), "--json", str(tmp_path / "d.json"), "--no-replay")
    clean(res, 0)
    report = json.loads((tmp_path / "d.json").read_text())
    assert sorted(report["baseline"]) == ["accel", "gyro", "mag"] and report["not_analysed"] == []
    (tmp_path / "empty").mkdir()
    res = rig("discrepancy", str(tmp_path / "empty"), "--json", str(tmp_path / "e.json"))
    clean(res, 2)
    assert "not a session folder" in res.stderr
    clean(rig("export", str(tmp_path / "empty"), "--to", str(tmp_path / "y")), 2)
    clean(rig("resume", str(tmp_path / "empty")), 2)


def _few_orientations(rig_session, folder, n=3):
    from rig.commands.common import read_any_session
    from rig.io.session_writer import write_session

    s = read_any_session(rig_session)
    keep = (s.step < n) & ~(s.is_move & (s.step == n - 1))
    sel = lambda a: None if a is None else a[keep]  # noqa: E731
    s = replace(s, t=s.t[keep], is_move=s.is_move[keep], step=s.step[keep], q_ref=s.q_ref[keep],
                raw={k: v[keep] for k, v in s.raw.items()}, table_deg=sel(s.table_deg), temp_c=sel(s.temp_c),
                vsupply_v=sel(s.vsupply_v))
    write_session(s, folder)
    return s


def test_discrepancy_says_which_sensors_it_could_not_analyse(rig_session, tmp_path):
    _few_orientations(rig_session, tmp_path / "three")
    res = rig("discrepancy", str(tmp_path / "three"), "--json", str(tmp_path / "t.json"), "--report",
              str(tmp_path / "r"), "--no-replay")
    clean(res, 1)
    assert "NOT analysed: accel, mag" in res.stderr
    assert "warning: not tested: accel" in res.stderr
    assert "explains them" not in res.stdout and "no missing effect found in gyro" in res.stdout
    assert json.loads((tmp_path / "t.json").read_text())["not_analysed"] == ["accel", "mag"]
    assert "**Not analysed: accel, mag**" in (tmp_path / "r" / "summary.md").read_text()


def test_an_implausible_number_is_refused_by_name_and_a_wild_plausible_one_does_not_crash(rig_session, tmp_path):
    from rig.commands.common import read_any_session
    from rig.io.session_writer import write_session

    s = read_any_session(rig_session)
    s.temp_c = s.temp_c.copy()
    s.temp_c[100] = 1e308
    write_session(s, tmp_path / "big")
    res = rig("discrepancy", str(tmp_path / "big"), "--json", str(tmp_path / "b.json"), "--no-replay")
    clean(res, 2)
    assert "samples.csv, line 102, column 'temp_c'" in res.stderr and "plausible range" in res.stderr

    s.temp_c[100] = 249.0
    write_session(s, tmp_path / "hot")
    res = rig("discrepancy", str(tmp_path / "hot"), "--json", str(tmp_path / "h.json"), "--no-replay")
    assert res.returncode in (0, 1, 3), res.stderr
    clean(res, res.returncode)
    assert "RuntimeWarning" not in res.stderr
    res = rig("calibrate", "--from", str(tmp_path / "hot"), "--out", str(tmp_path / "cal"))
    assert res.returncode in (0, 3), res.stderr
    clean(res, res.returncode)


def test_numpy_reprs_are_plain_numbers_in_messages():
    text = f"value {np.float64(1.5)!r} at {np.int64(3)!r}, flag {np.bool_(True)!r}"
    assert plain(text) == "value 1.5 at 3, flag True"
