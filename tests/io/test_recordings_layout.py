"""Recordings without a turntable in the interchange layout, and the plausible-range checks of every reader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rig.errors import SessionFormatError
from rig.io.session_csv import read_session
from rig.io.session_writer import write_session
from rig.session_data import SessionData


def recording(n: int = 400, units: dict | None = None, segments: list | None = None) -> SessionData:
    """A bench recording: no reference, no phases, accelerometer in m/s^2 and gyro in counts."""
    rng = np.random.default_rng(3)
    t = np.arange(n) / 100.0
    accel = np.array([0.1, -0.2, 9.8]) + rng.normal(0, 0.01, (n, 3))
    gyro = np.round(rng.normal(0, 3, (n, 3)))
    meta = {"reference": "none", "units": units or {"accel": "m/s^2"}, "segments": segments or []}
    return SessionData(t=t, is_move=np.ones(n, bool), step=np.full(n, -1), q_ref=np.full((n, 4), np.nan),
                       raw={"accel": accel, "gyro": gyro}, columns={"accel": ["ax", "ay", "az"],
                                                                     "gyro": ["gx", "gy", "gz"]},
                       temp_c=np.full(n, 24.5), meta=meta)


def test_a_recording_without_reference_or_phases_round_trips(tmp_path):
    rec = recording(segments=[{"name": "z_p", "t0": 0.5, "t1": 2.5, "kind": "static", "up": "+z", "tilt_deg_sd": 2.0},
                              {"name": "z_rot", "t0": 2.6, "t1": 3.5, "kind": "rotation", "axis": "+z",
                               "angle_deg": -360.0, "angle_deg_sd": 2.0}])
    folder = write_session(rec, tmp_path / "rec")
    header = (folder / "samples.csv").read_text().splitlines()[0].split(",")
    assert header == ["t", "ax", "ay", "az", "gx", "gy", "gz", "temp_c"]
    back = read_session(folder)
    assert back.meta["reference"] == "none" and back.meta["segments"][1]["angle_deg"] == -360.0
    assert np.array_equal(back.raw["accel"], rec.raw["accel"]), "physical units kept to the last digit"
    assert np.array_equal(back.raw["gyro"], rec.raw["gyro"])
    assert np.isnan(back.q_ref).all() and (back.step == -1).all() and back.is_move.all()


def test_a_count_column_still_needs_integers_when_another_sensor_is_in_physical_units(tmp_path):
    folder = write_session(recording(), tmp_path / "rec")
    text = (folder / "samples.csv").read_text().splitlines()
    cells = text[5].split(",")
    cells[4] = "3.25"                         # gx
    text[5] = ",".join(cells)
    (folder / "samples.csv").write_text("\n".join(text) + "\n")
    with pytest.raises(SessionFormatError) as info:
        read_session(folder)
    assert (info.value.line, info.value.column) == (6, "gx") and "'3.25' is not an integer" in str(info.value)


@pytest.mark.parametrize("column, value, words", [
    ("temp_c", "1e308", "outside the plausible range"),
    ("t", "1e308", "outside the plausible range"),
    ("ax", "1e9", "outside the plausible range"),
    ("gx", "99999999999", "outside the plausible range"),
])
def test_finite_but_absurd_values_are_refused_at_the_boundary(tmp_path, column, value, words):
    folder = write_session(recording(), tmp_path / "rec")
    lines = (folder / "samples.csv").read_text().splitlines()
    header = lines[0].split(",")
    row = len(lines) - 1 if column == "t" else 7     # the last t, so it still increases
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    lines[row] = ",".join(cells)
    (folder / "samples.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(SessionFormatError) as info:
        read_session(folder)
    assert (info.value.line, info.value.column) == (row + 1, column)
    assert words in str(info.value) and value in str(info.value)


@pytest.mark.parametrize("meta_change, key", [
    ({"reference": "tracker"}, "reference"),
    ({"units": {"accel": "g"}}, "units.accel"),
    ({"segments": [{"name": "a", "t0": 1.0, "t1": 0.5, "kind": "static"}]}, "segments[0] (a).t1"),
    ({"segments": [{"name": "r", "t0": 1.0, "t1": 2.0, "kind": "rotation", "axis": "+w", "angle_deg": 360}]},
     "segments[0] (r).axis"),
    ({"segments": [{"name": "r", "t0": 1.0, "t1": 2.0, "kind": "rotation", "axis": "+x", "angle_deg": 360,
                    "angle_deg_sd": -1}]}, "segments[0] (r).angle_deg_sd"),
])
def test_bad_recording_metadata_names_the_key(tmp_path, meta_change, key):
    folder = write_session(recording(), tmp_path / "rec")
    meta = json.loads((folder / "meta.json").read_text())
    meta.update(meta_change)
    (folder / "meta.json").write_text(json.dumps(meta, indent=2))
    with pytest.raises(SessionFormatError) as info:
        read_session(folder)
    assert info.value.column == key and Path(info.value.file).name == "meta.json"


def test_a_session_with_a_turntable_still_needs_its_quaternions(tmp_path):
    folder = tmp_path / "rec"
    write_session(recording(), folder)
    meta = json.loads((folder / "meta.json").read_text())
    meta["reference"] = "table"
    (folder / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(SessionFormatError) as info:
        read_session(folder)
    assert info.value.line == 1 and info.value.column == "phase"
