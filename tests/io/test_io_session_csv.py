"""The interchange layout: round trip, empty cells, and every broken rule named by file, line and column."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from io_synthetic import build_session

from rig.errors import SessionFormatError
from rig.io.session_csv import read_session
from rig.io.session_writer import write_session


@pytest.fixture(scope="module")
def session():
    s, _ = build_session(seed=3, hold_s=1.0, schedule_deg=np.array([[0, 0], [90, 0], [90, 90], [180, 45]]))
    return s


@pytest.fixture
def folder(tmp_path, session) -> Path:
    return write_session(session, tmp_path / "s")


def edit_cell(folder: Path, line: int, column: str, value: str) -> None:
    path = folder / "samples.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[line - 1].split(",")
    cells[header.index(column)] = value
    lines[line - 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def edit_meta(folder: Path, change) -> None:
    path = folder / "meta.json"
    meta = json.loads(path.read_text())
    change(meta)
    path.write_text(json.dumps(meta, indent=2))


def expect_error(folder: Path, file: str, line: int | None, column: str | None, words: str) -> SessionFormatError:
    with pytest.raises(SessionFormatError) as info:
        read_session(folder)
    err = info.value
    assert Path(err.file).name == file
    assert (err.line, err.column) == (line, column)
    assert words in str(err)
    assert f"line {line}" in str(err) if line is not None else True
    return err


def test_round_trip_keeps_every_array_and_unknown_meta(folder, session):
    back = read_session(folder)
    np.testing.assert_array_equal(back.t, session.t)
    np.testing.assert_array_equal(back.is_move, session.is_move)
    np.testing.assert_array_equal(back.step, session.step)
    np.testing.assert_allclose(back.q_ref, session.q_ref, rtol=0, atol=1e-15)
    for name in session.raw:
        np.testing.assert_array_equal(back.raw[name], session.raw[name])
    np.testing.assert_array_equal(back.table_deg, session.table_deg)
    np.testing.assert_array_equal(back.temp_c, session.temp_c)
    np.testing.assert_array_equal(back.vsupply_v, session.vsupply_v)
    assert back.columns == session.columns
    assert (back.gravity, back.field_uT, back.sample_rate_hz) == (session.gravity, session.field_uT, 100.0)
    assert back.meta["operator"] == "synthetic"
    assert back.meta["format"] == "imu-session-csv/1"


def test_counts_written_as_integers_and_nan_as_empty_cells(folder):
    lines = (folder / "samples.csv").read_text().splitlines()
    header = lines[0].split(",")
    row1, row2 = lines[1].split(","), lines[2].split(",")
    mx = header.index("mx")
    assert row1[mx].lstrip("-").isdigit() and row1[header.index("az")].lstrip("-").isdigit()
    assert row2[mx:mx + 3] == ["", "", ""]


def test_empty_mag_cells_read_as_no_sample(folder, session):
    back = read_session(folder)
    have = ~np.isnan(back.raw["mag"]).any(axis=1)
    np.testing.assert_array_equal(have, ~np.isnan(session.raw["mag"]).any(axis=1))
    assert have[0] and not have[1]
    assert not np.isnan(back.raw["accel"]).any()


def test_extra_meta_merged_and_session_meta_untouched(tmp_path, session):
    out = write_session(session, tmp_path / "x", extra_meta={"rig_serial": "T-7"})
    meta = json.loads((out / "meta.json").read_text())
    assert meta["rig_serial"] == "T-7" and meta["operator"] == "synthetic"
    assert "rig_serial" not in session.meta


def test_write_refuses_fractional_counts(tmp_path, session):
    bad = read_session(write_session(session, tmp_path / "a"))
    bad.raw["accel"][5, 1] += 0.5
    with pytest.raises(ValueError, match="'ay'.*row 5"):
        write_session(bad, tmp_path / "b")


def test_bad_phase(folder):
    edit_cell(folder, 7, "phase", "hlod")
    expect_error(folder, "samples.csv", 7, "phase", "'hlod' is not 'hold' or 'move'")


def test_time_going_backwards(folder):
    edit_cell(folder, 12, "t", "0.05")
    expect_error(folder, "samples.csv", 12, "t", "not after the previous row")


def test_repeated_time(folder):
    lines = (folder / "samples.csv").read_text().splitlines()
    t_prev = lines[8].split(",")[0]
    edit_cell(folder, 10, "t", t_prev)
    expect_error(folder, "samples.csv", 10, "t", "monotonic")


def test_missing_required_column(folder):
    path = folder / "samples.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    k = header.index("qy")
    path.write_text("\n".join(",".join(c for i, c in enumerate(l.split(",")) if i != k) for l in lines) + "\n")
    expect_error(folder, "samples.csv", 1, "qy", "required column missing")


def test_missing_sensor_column_named_by_meta(folder):
    edit_meta(folder, lambda m: m["sensors"].__setitem__("gyro", ["gx", "gy", "gyro_z"]))
    expect_error(folder, "samples.csv", 1, "gyro_z", "sensor 'gyro'")


@pytest.mark.parametrize("value", ["12.5", "1e3", "nan", "x"])
def test_non_integer_count(folder, value):
    edit_cell(folder, 20, "gy", value)
    expect_error(folder, "samples.csv", 20, "gy", f"{value!r} is not an integer")


def test_partly_empty_sensor_row(folder):
    edit_cell(folder, 4, "az", "")
    expect_error(folder, "samples.csv", 4, "az", "some but not all")


def test_quaternion_not_unit(folder):
    edit_cell(folder, 30, "qx", "0.2")
    expect_error(folder, "samples.csv", 30, "qw,qx,qy,qz", "quaternion norm")


def test_quaternion_cell_empty(folder):
    edit_cell(folder, 31, "qz", "")
    expect_error(folder, "samples.csv", 31, "qz", "empty cell")


def test_negative_w_is_the_same_rotation(folder, session):
    path = folder / "samples.csv"
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[40].split(",")
    for c in ("qw", "qx", "qy", "qz"):
        v = cells[header.index(c)]
        cells[header.index(c)] = v[1:] if v.startswith("-") else "-" + v
    lines[40] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    back = read_session(folder)
    np.testing.assert_allclose(back.q_ref[39], session.q_ref[39], atol=1e-15)


def test_non_finite_float(folder):
    edit_cell(folder, 9, "temp_c", "inf")
    expect_error(folder, "samples.csv", 9, "temp_c", "not a finite number")


def test_non_integer_step(folder):
    edit_cell(folder, 15, "step", "1.5")
    expect_error(folder, "samples.csv", 15, "step", "'1.5' is not an integer")


def test_short_row(folder):
    path = folder / "samples.csv"
    lines = path.read_text().splitlines()
    lines[24] = ",".join(lines[24].split(",")[:5])
    path.write_text("\n".join(lines) + "\n")
    expect_error(folder, "samples.csv", 25, "qy", "row has 5 cells")


def test_duplicate_header_column(folder):
    path = folder / "samples.csv"
    text = path.read_text().replace("vsupply_v", "temp_c", 1)
    path.write_text(text)
    expect_error(folder, "samples.csv", 1, "temp_c", "named twice")


def test_missing_field_names_line_of_mag(folder):
    edit_meta(folder, lambda m: m.pop("field_uT"))
    text = (folder / "meta.json").read_text().splitlines()
    mag_line = next(i for i, l in enumerate(text, 1) if '"mag"' in l)
    with pytest.raises(SessionFormatError) as info:
        read_session(folder)
    assert (info.value.line, info.value.column) == (mag_line, "field_uT")


def test_wrong_format_and_bad_json(folder):
    edit_meta(folder, lambda m: m.__setitem__("format", "imu-session-csv/2"))
    with pytest.raises(SessionFormatError, match="format must be 'imu-session-csv/1'") as info:
        read_session(folder)
    assert info.value.column == "format" and info.value.line == 2
    (folder / "meta.json").write_text('{\n  "format": "imu-session-csv/1",\n  "sensors": {,}\n}')
    with pytest.raises(SessionFormatError, match="not valid JSON") as info:
        read_session(folder)
    assert info.value.line == 3


def test_unknown_sensor_and_missing_gravity(folder):
    edit_meta(folder, lambda m: m["sensors"].__setitem__("baro", ["p", "q", "r"]))
    with pytest.raises(SessionFormatError, match="unknown sensor 'baro'"):
        read_session(folder)
    edit_meta(folder, lambda m: (m["sensors"].pop("baro"), m.pop("gravity_mps2")))
    with pytest.raises(SessionFormatError, match="gravity_mps2"):
        read_session(folder)


def test_missing_files(tmp_path):
    with pytest.raises(SessionFormatError, match="meta.json.*missing"):
        read_session(tmp_path)


def test_subset_of_sensors_without_table_columns(tmp_path):
    s, _ = build_session(seed=4, hold_s=0.5, sensors=("accel",), schedule_deg=np.array([[0, 0], [45, 30]]))
    s.table_deg = None
    s.temp_c = None
    back = read_session(write_session(s, tmp_path / "acc"))
    assert back.sensors == ["accel"] and back.table_deg is None and back.temp_c is None and back.field_uT is None
    np.testing.assert_array_equal(back.raw["accel"], s.raw["accel"])


def test_windows_line_endings_and_bom(folder, session):
    path = folder / "samples.csv"
    path.write_bytes(b"\xef\xbb\xbf" + path.read_text().replace("\n", "\r\n").encode())
    back = read_session(folder)
    np.testing.assert_array_equal(back.raw["gyro"], session.raw["gyro"])
    assert back.columns == session.columns


def test_write_refuses_what_read_would_refuse(tmp_path, session):
    bad = read_session(write_session(session, tmp_path / "a"))
    bad.t[7] = bad.t[6]
    with pytest.raises(ValueError, match="t must increase: row 7"):
        write_session(bad, tmp_path / "b")
    bad = read_session(tmp_path / "a")
    bad.q_ref[3] *= 1.1
    with pytest.raises(ValueError, match="q_ref row 3"):
        write_session(bad, tmp_path / "c")


def test_layout_keys_win_over_extra_meta(tmp_path, session):
    out = write_session(session, tmp_path / "x", extra_meta={"format": "other/9", "gravity_mps2": 1.0,
                                                              "bench": np.float64(2.5)})
    meta = json.loads((out / "meta.json").read_text())
    assert (meta["format"], meta["gravity_mps2"], meta["bench"]) == ("imu-session-csv/1", session.gravity, 2.5)


def test_move_step_must_be_the_hold_it_leaves(folder, session):
    first_move = int(np.argmax(session.is_move))
    edit_cell(folder, first_move + 3, "step", "1")
    expect_error(folder, "samples.csv", first_move + 3, "step", "the hold it leaves has step 0")


def test_a_hold_split_in_two_runs_is_an_error_naming_the_line(tmp_path):
    """Rows of hold 3 interrupted by other rows: refuse rather than silently keep one part."""
    from rig.io.session_csv import read_session
    from rig.io.session_writer import write_session

    session, _ = build_session(seed=1)
    holds = session.hold_rows()
    step3 = dict(holds)[3]
    middle = step3[len(step3) // 2]
    session.step[middle] = 4
    write_session(session, tmp_path / "s")
    with pytest.raises(SessionFormatError) as err:
        read_session(tmp_path / "s")
    assert err.value.line == (middle + 1) + 2 and err.value.column == "step"   # the row after the changed one
    assert "hold step 3 appears again" in str(err.value)
