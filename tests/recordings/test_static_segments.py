"""A static segment the user wrote that holds a motion (its t1 run into the flip after it, a turn written as a pose) is
refused before any fit, naming the segment; before, both calibrated with exit 0 to a gyro bias of several deg/s.
Poses held by a shaking hand are not refused."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ferraris_synth import generate  # noqa: E402
from test_unseen_recordings import one_clear_line, rig  # noqa: E402

from rig.calibration.recordings.segments import segments_of  # noqa: E402
from rig.calibration.recordings.static_segments import check_static_segments  # noqa: E402
from rig.errors import InputError  # noqa: E402
from rig.io.session_csv import read_session  # noqa: E402
from rig.io.session_writer import write_session  # noqa: E402


def written(tmp_path: Path, edit=None, **kw) -> Path:
    session, _ = generate(3, **kw)
    folder = write_session(session, tmp_path / "s")
    if edit is not None:
        meta = json.loads((folder / "meta.json").read_text())
        edit(meta["segments"])
        (folder / "meta.json").write_text(json.dumps(meta, indent=1))
    return folder


def run_into_the_next_motion(segments):
    first, second = segments[0], segments[1]
    first["t1"] = (first["t1"] + second["t0"]) / 2                    # half way into the flip to the next face


def turn_written_as_a_pose(segments):
    turn = next(s for s in segments if s["kind"] == "rotation")
    turn.update(kind="static", up=turn.pop("axis"), tilt_deg_sd=2.0)
    del turn["angle_deg"], turn["angle_deg_sd"]


@pytest.mark.parametrize("edit, name", [(run_into_the_next_motion, "x_p"), (turn_written_as_a_pose, "x_rot")])
def test_a_static_segment_that_holds_a_motion_is_refused_naming_it(tmp_path, edit, name):
    folder = written(tmp_path, edit)
    out = tmp_path / "cal"
    done = rig("calibrate", "--from", str(folder), "--out", str(out), "--no-progress")
    assert done.returncode == 2, (done.returncode, done.stdout[-500:], done.stderr)
    line = one_clear_line(done)
    assert str(folder / "meta.json") in line and f"static segment '{name}'" in line, line
    assert not (out / "calibration.json").exists()
    done = rig("discrepancy", str(folder), "--json", str(tmp_path / "d.json"))
    assert done.returncode == 2 and f"static segment '{name}'" in one_clear_line(done), done.stderr
    assert done.stderr.count(str(folder)) == 1, done.stderr          # the file names the folder; not twice


def test_a_gyro_in_counts_is_read_at_the_scale_of_the_recordings_turns(tmp_path):
    """The gyro sees a turn about the vertical that the accelerometer cannot; in counts it is read at the scale the
    recording's turns of known angle give, so the degrees it names are the turn's."""
    session = read_session(written(tmp_path, turn_written_as_a_pose))
    assert session.meta["units"]["gyro"] == "counts"
    poses, turns = segments_of(session)
    with pytest.raises(InputError, match="static segment 'x_rot'") as refused:
        check_static_segments(session, poses, turns)
    worst = float(re.search(r"\((\d+) deg in its worst second\)", str(refused.value)).group(1))
    assert 150 < worst < 200, str(refused.value)      # 360 deg in 4 s at a raised-cosine rate: 171 deg at most


def test_poses_held_by_a_shaking_hand_are_not_refused(tmp_path):
    """Hand motions that swing by 10 deg, faces tilted by 3 deg and counts of noise three times the default still
    calibrate: the limit is for a motion, not for a hand."""
    folder = written(tmp_path, shake_deg=10.0, tilt_deg=3.0, accel_noise=3.0, gyro_noise=3.0)
    done = rig("calibrate", "--from", str(folder), "--out", str(tmp_path / "cal"), "--no-progress")
    assert done.returncode == 0, (done.stdout[-500:], done.stderr)
