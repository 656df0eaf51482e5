"""Which command takes which recording kind is said once (`rig.recording_kinds`): the reference page holds the
table it makes, and a command given a recording it cannot use refuses it before any work, exit 2, naming the
sensor it lacks and the commands that take it (a gyro-only recording was imported with 0 and refused by
`rig calibrate` with 3; `rig discrepancy` on a magnetometer log failed deep in its twin)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_unseen_recordings import one_clear_line, recording, rig  # noqa: E402

from rig.recording_kinds import COMMANDS, markdown_table, recording_kinds, use  # noqa: E402

PAGE = Path(__file__).resolve().parents[2] / "docs" / "reference" / "recording-kinds.md"
COLUMNS = {"accel": "ax,ay,az", "gyro": "gx,gy,gz", "mag": "mx,my,mz"}
UNITS = {"accel": "m/s^2", "gyro": "rad/s", "mag": "uT"}


def test_the_reference_page_holds_the_table_the_module_makes():
    assert markdown_table() in PAGE.read_text(), "regenerate it: python -m rig.recording_kinds"


def test_every_recording_kind_is_taken_by_some_command_and_calibrate_takes_every_accelerometer_or_magnetometer():
    for kind in recording_kinds():
        assert any(use(c, False, kind).taken for c in COMMANDS), kind
        assert use("calibrate", False, kind).taken == bool(kind & {"accel", "mag"})
        assert use("discrepancy", False, kind).taken == ({"accel", "gyro"} <= kind or "gyro" not in kind)


def imported(tmp_path: Path, sensors: tuple[str, ...]) -> Path:
    """A hand-placed recording of these sensors, through `rig import csv`."""
    rec = recording(1, poses=4, rest_s=5.0)
    mag = np.random.default_rng(0).normal(0.0, 1.0, rec["accel"].shape) + [20.0, 0.0, -40.0]
    data = {"accel": rec["accel"], "gyro": rec["gyro"], "mag": mag}
    header = ",".join(["t"] + [c for s in sensors for c in COLUMNS[s].split(",")])
    np.savetxt(tmp_path / "log.csv", np.column_stack([rec["t"]] + [data[s] for s in sensors]), delimiter=",",
               header=header, comments="", fmt="%.5f")
    args = [a for s in sensors for a in (f"--{s}", COLUMNS[s])]
    units = ",".join(f"{s}={UNITS[s]}" for s in sensors)
    done = rig("import", "csv", str(tmp_path / "log.csv"), "--time", "t", *args, "--units", units,
               "--out", str(tmp_path / "s"))
    assert done.returncode == 0, done.stderr
    return tmp_path / "s"


@pytest.mark.parametrize("sensors,lacking,taken_by", [
    (("gyro", "mag"), "it needs an accelerometer", "`rig calibrate --from` and `rig noise` take it"),
    (("gyro",), "it needs an accelerometer", "`rig noise` takes it"),
])
def test_rig_discrepancy_refuses_a_recording_without_what_its_twin_replays(tmp_path, sensors, lacking, taken_by):
    folder = imported(tmp_path, sensors)
    done = rig("discrepancy", str(folder), "--json", str(tmp_path / "d.json"))
    assert done.returncode == 2, (done.returncode, done.stderr)
    line = one_clear_line(done)
    assert f"kind {'+'.join(sensors)}" in line and lacking in line and taken_by in line, line
    assert not (tmp_path / "d.json").exists()


def test_rig_calibrate_refuses_a_gyroscope_alone_naming_what_it_needs(tmp_path):
    folder = imported(tmp_path, ("gyro",))
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "c"))
    assert done.returncode == 2, (done.returncode, done.stderr)
    line = one_clear_line(done)
    assert "it needs an accelerometer or a magnetometer" in line and "`rig noise` takes it" in line, line
    assert not (tmp_path / "c").exists()
