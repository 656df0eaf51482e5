"""`rig plan` (dry run and observability) and configuration errors."""

import subprocess
import sys

import pytest

from rig.config import load_config


def rig(*args):
    return subprocess.run([sys.executable, "-m", "rig.cli", *args], capture_output=True, text=True, timeout=120)


def test_plan_lists_the_schedule_and_an_eta():
    res = rig("plan")
    assert res.returncode == 0, res.stderr
    assert "every axis excited" in res.stdout
    rows = [line for line in res.stdout.splitlines() if line[:3].strip().isdigit() and len(line.split()) == 3]
    assert len(rows) == 20
    assert "estimated rig time" in res.stdout


def test_plan_refuses_a_vertical_outer_axis_and_names_the_blind_axis(tmp_path):
    cfg = tmp_path / "vertical.toml"
    cfg.write_text('[unit]\nboard = "bsn"\n[table]\nouter_axis_world = [0, 0, 1]\ninner_axis_fixture = [1, 0, 0]\n')
    res = rig("plan", "--config", str(cfg))
    assert res.returncode == 1
    line = next(line for line in res.stdout.splitlines() if line.startswith("observability"))
    assert "accel" in line and "x" in line


def test_calibrate_refuses_an_unobservable_schedule_before_anything_moves(tmp_path):
    cfg = tmp_path / "vertical.toml"
    cfg.write_text('[unit]\nboard = "bsn"\n[table]\nouter_axis_world = [0, 0, 1]\ninner_axis_fixture = [1, 0, 0]\n')
    res = rig("calibrate", "--sim", "--config", str(cfg), "--out", str(tmp_path / "out"))
    assert res.returncode != 0
    assert "cannot excite" in res.stderr
    assert not (tmp_path / "out" / "session.sqlite").exists()


@pytest.mark.parametrize("text,needle", [
    ('[unit]\nboard = "tablet"\n', "board = 'tablet'"),
    ('[schedule]\norientations = 8\n', "orientations = 8"),
    ('[turntable]\nspeed = 3\n', "unknown keys ['speed']"),
    ('[unit\n', "not valid TOML"),
    ('[environment]\ngravity = 9.7\n', "[environment] has unknown keys ['gravity']"),
    ('[schedul]\nhold_s = 5\n', "unknown sections ['schedul']"),
    ('[turntable]\nspeed_dps = "fast"\n', "[turntable] speed_dps = 'fast' must be a number"),
    ('[schedule]\norientations = 12.5\n', "[schedule] orientations = 12.5 must be a whole number"),
    ('[schedule]\nhold_s = nan\n', "[schedule] hold_s = nan must be a finite number"),
    ('[turntable]\nsettle_s = inf\n', "[turntable] settle_s = inf must be a finite number"),
    ('[environment]\ngravity_mps2 = -inf\n', "[environment] gravity_mps2 = -inf must be a positive finite number"),
    ('[environment]\nfield_uT = "strong"\n', "[environment] field_uT = 'strong' must be a positive finite number"),
    ('[store]\nurl = 5\n', "[store] url = 5 must be a non-empty string"),
    ('[store]\nhost = "db"\n', "[store] has unknown keys ['host']"),
])
def test_bad_configuration_is_an_error_naming_the_file_and_field(tmp_path, text, needle):
    """Misspelt or mistyped settings are errors, never silently ignored."""
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    with pytest.raises(ValueError) as err:
        load_config(cfg)
    assert str(cfg) in str(err.value) and needle in str(err.value)
