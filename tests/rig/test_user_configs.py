"""Rig configurations as lab engineers write them: each mistake is one message naming the file and the key,
exit 2, before anything is created or moves (docs/reference/configuration.md, exit-codes.md)."""

import subprocess
import sys
from importlib import resources

import pytest

from rig.config import load_config

SIM_TOML = resources.files("rig.configs").joinpath("sim.toml").read_text()
UNIT_TABLE = SIM_TOML[SIM_TOML.index("[unit]\n"):SIM_TOML.index("\n[", SIM_TOML.index("[unit]\n")) + 1]


def rig(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "rig.cli", *args], capture_output=True, text=True, timeout=timeout)


def edited(old: str, new: str) -> str:
    assert old in SIM_TOML, old
    return SIM_TOML.replace(old, new, 1)


@pytest.mark.parametrize("old,new,needle", [
    # [table] geometry: a scalar crashed (exit 70), a string named neither file nor key, a zero or NaN axis
    # made every orientation NaN (exit 3 naming "schedule")
    ("outer_axis_world = [1.0, 0.0, 0.0]", "outer_axis_world = 1", "[table] outer_axis_world = 1 must be"),
    ("outer_axis_world = [1.0, 0.0, 0.0]", 'outer_axis_world = ["a", 0, 0]', "[table] outer_axis_world = ['a'"),
    ("outer_axis_world = [1.0, 0.0, 0.0]", "outer_axis_world = [1, 0]", "[table] outer_axis_world = [1, 0] must"),
    ("outer_axis_world = [1.0, 0.0, 0.0]", "outer_axis_world = [0, 0, 0]", "[table] outer_axis_world = [0, 0, 0]"),
    ("outer_axis_world = [1.0, 0.0, 0.0]", "outer_axis_world = [nan, 0, 0]", "[table] outer_axis_world = [nan"),
    ("[table]\n", '[table]\nouter_zero_deg = "a"\n', "[table] outer_zero_deg = 'a' must be a finite number"),
    ("[table]\n", "[table]\ninner_zero_deg = nan\n", "[table] inner_zero_deg = nan must be a finite number"),
    # values a rig cannot run: mag_every = 0 failed the created session (ZeroDivisionError, exit 70),
    # settle_s = -1 and hold_s = 0.01 ran, hold_s = 1e308 crashed `rig plan`, speed_dps = 0.001 and
    # settle_s = 1e6 made `rig plan` run out of memory
    ("mag_every = 2", "mag_every = 0", "[schedule] mag_every = 0 must be in 1..1000"),
    ("mag_every = 2", "mag_every = -1", "[schedule] mag_every = -1 must be in"),
    ("hold_s = 5.0", "hold_s = 0.01", "[schedule] hold_s = 0.01 must be in"),
    ("hold_s = 5.0", "hold_s = 1e308", "[schedule] hold_s = 1e+308 must be in"),
    ("rate_hz = 100.0", "rate_hz = 0.001", "[schedule] rate_hz = 0.001 must be in"),
    ("speed_dps = 120.0", "speed_dps = 0.001", "[turntable] speed_dps = 0.001 must be in"),
    ("settle_s = 0.3", "settle_s = 1e6", "[turntable] settle_s = 1000000.0 must be in"),
    ("settle_s = 0.3", "settle_s = -1", "[turntable] settle_s = -1 must be in"),
    ("tolerance_deg = 0.01", "tolerance_deg = 100", "[turntable] tolerance_deg = 100 must be in"),
    ("settle_s = 0.3", "settle_s = 0.3\nwatchdog_ms = -5", "[turntable] watchdog_ms = -5 must be in"),
    # strings: url = 5 crashed the turntable client (exit 70), profile = 5 crashed `rig plan`
    ('url = "tcp://127.0.0.1:0"', "url = 5", "[turntable] url = 5 must be a string"),
    ("settle_s = 0.3", "settle_s = 0.3\nprofile = 5", "[turntable] profile = 5 must be a string"),
    # a section given as a value: its characters were read as keys ("[unit] has unknown keys ['x']"), or
    # an empty one crashed
    (UNIT_TABLE, 'unit = ""\n', 'unit = \'\' must be a table'),
    (UNIT_TABLE, 'unit = "x"\n', "unit = 'x' must be a table"),
])
def test_a_value_no_rig_can_use_is_refused_naming_file_and_key(tmp_path, old, new, needle):
    cfg = tmp_path / "rig.toml"
    cfg.write_text(edited(old, new))
    with pytest.raises(ValueError) as err:
        load_config(cfg)
    assert str(err.value).startswith(f"{cfg}: ") and needle in str(err.value), str(err.value)


def test_plan_refuses_a_zero_axis_as_bad_input_naming_the_key(tmp_path):
    cfg = tmp_path / "rig.toml"
    cfg.write_text(edited("outer_axis_world = [1.0, 0.0, 0.0]", "outer_axis_world = [0, 0, 0]"))
    res = rig("plan", "--config", str(cfg))
    assert res.returncode == 2, res.stderr
    assert f"{cfg}: [table] outer_axis_world" in res.stderr and "Traceback" not in res.stderr


def test_a_missing_profile_is_bad_input_naming_the_key_before_a_folder_is_made(tmp_path):
    """It was a turntable fault (exit 3, "key '<file>': no such file") once the session had started."""
    cfg = tmp_path / "rig.toml"
    cfg.write_text(edited("settle_s = 0.3", 'settle_s = 0.3\nprofile = "my-table.toml"'))
    with pytest.raises(ValueError) as err:
        load_config(cfg)
    assert str(err.value).startswith(f"{cfg}: [turntable] profile = 'my-table.toml'")
    assert str(tmp_path / "my-table.toml") in str(err.value)
    res = rig("calibrate", "--sim", "--config", str(cfg), "--out", str(tmp_path / "out"), "--no-progress")
    assert res.returncode == 2 and "[turntable] profile" in res.stderr, res.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("extra,needle", [
    # a misspelt sensor's limits were never checked, and the verdict said PASS
    ("[limits.acel]\nresidual_rms_max = 0.05\n", "[limits.acel]: no such sensor"),
    # the ADC was emulated although the file says it is real
    ('[sim.chips]\nadc = "real"\naccel = "fake"\n', "[sim.chips] accel = 'fake' but adc = 'real'"),
])
def test_a_setting_that_would_be_silently_overridden_is_refused(tmp_path, extra, needle):
    cfg = tmp_path / "rig.toml"
    cfg.write_text(SIM_TOML + "\n" + extra)
    with pytest.raises(ValueError) as err:
        load_config(cfg)
    assert str(err.value).startswith(f"{cfg}: ") and needle in str(err.value), str(err.value)


def test_a_fault_plan_error_names_the_file_once(tmp_path):
    cfg = tmp_path / "rig.toml"
    cfg.write_text(SIM_TOML + "\n[sim.faults]\nmodbus_drop = 0.1\n")
    with pytest.raises(ValueError) as err:
        load_config(cfg)
    assert str(err.value).count(str(cfg)) == 1 and "['modbus_drop']" in str(err.value)


@pytest.mark.parametrize("value", ["-50", '"fast"'])
def test_a_chip_setting_the_driver_refuses_is_bad_input_naming_file_and_part(tmp_path, value):
    """It was an internal error (exit 70) once the drivers were attached."""
    cfg = tmp_path / "rig.toml"
    cfg.write_text(SIM_TOML + f"\n[chips.gyro]\nrate_hz = {value}\n")
    res = rig("calibrate", "--sim", "--config", str(cfg), "--out", str(tmp_path / "out"), "--no-progress")
    assert res.returncode == 2, res.stderr
    assert f"{cfg}: [chips.gyro] (ITG-3200)" in res.stderr and "internal error" not in res.stderr
    assert not (tmp_path / "out" / "session.sqlite").exists()


@pytest.mark.parametrize("command", [["plan"], ["calibrate", "--sim", "--no-progress"]])
def test_orientations_with_a_budget_is_refused_not_silently_ignored(tmp_path, command):
    """`--orientations 12 --budget-s 60` ran the planner's 19 orientations without a word."""
    res = rig(*command, "--budget-s", "60", "--orientations", "12", *(["--out", str(tmp_path / "out")]
                                                                       if "calibrate" in command else []))
    assert res.returncode == 2, res.stdout + res.stderr
    assert "--orientations" in res.stderr and "--budget-s" in res.stderr
    assert not (tmp_path / "out").exists()
