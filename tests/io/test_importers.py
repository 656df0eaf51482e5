"""`rig import imu_tk|ferraris|csv`: the peers' real recordings and synthetic ones become ordinary sessions."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rig.errors import InputError, SessionFormatError
from rig.io.import_csv import import_csv
from rig.io.import_ferraris import import_ferraris
from rig.io.import_imu_tk import import_imu_tk
from rig.io.session_csv import read_session
from rig.io.session_writer import write_session

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from paths import DATA  # noqa: E402

FERRARIS = DATA / "imucal-ferraris"
XSENS = DATA / "imu_tk-xsens"
RIG = [sys.executable, "-m", "rig.cli"]


def test_imucal_continuous_session_and_its_section_list(tmp_path):
    session = import_ferraris(rate_hz=102.4, units={"accel": "m/s^2", "gyro": "deg/s"},
                              csv=FERRARIS / "example_ferraris_session.csv",
                              sections=FERRARIS / "example_ferraris_session_list.json")
    doc = json.loads((FERRARIS / "example_ferraris_session_list.json").read_text())
    segs = {s["name"]: s for s in session.meta["segments"]}
    assert set(segs) == set(doc)
    for name, span in doc.items():                     # imucal's iloc[start:end], end exclusive
        assert segs[name]["t0"] == pytest.approx(span["start"] / 102.4)
        assert segs[name]["t1"] == pytest.approx((span["end"] - 1) / 102.4)
    for face in ("x_p", "y_p", "z_p"):
        rows = (session.t >= segs[face]["t0"]) & (session.t <= segs[face]["t1"])
        axis = "xyz".index(face[0])
        assert session.raw["accel"][rows, axis].mean() > 9.0, f"{face}: +{face[0]} up reads +g"
        assert (~session.is_move[rows]).all()
    back = read_session(write_session(session, tmp_path / "s"))
    assert back.meta["units"] == {"accel": "m/s^2", "gyro": "deg/s"}
    assert np.allclose(back.raw["gyro"], session.raw["gyro"], rtol=0, atol=0)


def test_the_two_imucal_examples_turn_opposite_ways_and_the_sense_is_read_from_the_data():
    continuous = import_ferraris(rate_hz=102.4, units={"accel": "m/s^2", "gyro": "deg/s"},
                                 csv=FERRARIS / "example_ferraris_session.csv",
                                 sections=FERRARIS / "example_ferraris_session_list.json")
    cut = import_ferraris(rate_hz=204.8, units={"accel": "counts", "gyro": "counts"},
                          annotated=FERRARIS / "annotated_session.csv")
    for session, sign in ((continuous, -1), (cut, +1)):
        turns = [s for s in session.meta["segments"] if s["kind"] == "rotation"]
        assert [s["angle_deg"] for s in turns] == [sign * 360.0] * 3
        for seg in turns:
            rows = (session.t >= seg["t0"]) & (session.t <= seg["t1"])
            axis = "xyz".index(seg["axis"][1])
            assert np.sign(session.raw["gyro"][rows, axis].sum()) == sign, "the sense is the gyro's own"
    assert len(cut.t) == 9414 and np.all(np.diff(cut.t) > 0)


def test_a_given_turn_angle_is_kept():
    session = import_ferraris(rate_hz=204.8, units={}, annotated=FERRARIS / "annotated_session.csv", turn_deg=-360)
    assert {s["angle_deg"] for s in session.meta["segments"] if s["kind"] == "rotation"} == {-360.0}


def test_imu_tk_files_become_one_session_sampled_together():
    session = import_imu_tk({"accel": XSENS / "xsens_acc.mat", "gyro": XSENS / "xsens_gyro.mat"}, gravity=9.81744)
    assert len(session.t) == 51175 and session.meta["units"] == {"accel": "counts", "gyro": "counts"}
    assert session.sample_rate_hz == pytest.approx(100, rel=0.01)
    assert session.meta["segments"] == [] and (session.step == -1).all()


def test_imu_tk_files_with_other_time_stamps_are_refused(tmp_path):
    a = tmp_path / "acc.txt"
    g = tmp_path / "gyr.txt"
    a.write_text("".join(f"{0.01 * k:.2f} 1 2 3\n" for k in range(10)))
    g.write_text("".join(f"{0.01 * k + (0.005 if k == 6 else 0):.3f} 1 2 3\n" for k in range(10)))
    with pytest.raises(SessionFormatError) as info:
        import_imu_tk({"accel": a, "gyro": g})
    assert Path(info.value.file) == g and info.value.line == 7


def logger_csv(path: Path, n: int = 500, time_ms: bool = True) -> None:
    rng = np.random.default_rng(1)
    rows = ["stamp_ms;ax_g;ay_g;az_g;wx;wy;wz;temp"]
    for k in range(n):
        a = np.array([0.01, -0.02, 1.0]) + rng.normal(0, 0.001, 3)
        w = np.round(rng.normal(0, 2, 3))
        rows.append(";".join([f"{1000 + 10 * k}", *(f"{v:.5f}" for v in a), *(f"{int(v)}" for v in w), "31.5"]))
    path.write_text("\n".join(rows) + "\n")


def test_a_loggers_csv_with_a_column_map(tmp_path):
    logger_csv(tmp_path / "log.csv")
    session = import_csv(tmp_path / "log.csv", {"accel": ["ax_g", "ay_g", "az_g"], "gyro": ["wx", "wy", "wz"]},
                         units={"accel": "g", "gyro": "counts"}, time_column="stamp_ms", time_unit="ms",
                         temp_column="temp", delimiter=";")
    assert session.t[0] == pytest.approx(1.0) and np.diff(session.t) == pytest.approx(0.01)
    assert session.raw["accel"][:, 2].mean() == pytest.approx(9.80665, abs=0.01), "g converted to m/s^2"
    assert session.meta["units"] == {"accel": "m/s^2", "gyro": "counts"}
    assert session.temp_c[0] == 31.5
    back = read_session(write_session(session, tmp_path / "s"))
    assert np.allclose(back.raw["accel"], session.raw["accel"], rtol=0, atol=0)


@pytest.mark.parametrize("kwargs, words", [
    ({"time_column": "stamp_ms", "rate_hz": 100.0}, "either --time"),
    ({}, "either --time"),
    ({"time_column": "stamp_ms", "time_unit": "min"}, "--time-unit"),
])
def test_the_time_options_must_say_one_thing(tmp_path, kwargs, words):
    logger_csv(tmp_path / "log.csv")
    with pytest.raises(InputError, match=words):
        import_csv(tmp_path / "log.csv", {"gyro": ["wx", "wy", "wz"]}, units={}, delimiter=";", **kwargs)


def test_a_scaled_column_read_as_counts_says_how_to_give_units(tmp_path):
    logger_csv(tmp_path / "log.csv")
    with pytest.raises(InputError) as info:
        import_csv(tmp_path / "log.csv", {"accel": ["ax_g", "ay_g", "az_g"]}, units={}, time_column="stamp_ms",
                   time_unit="ms", delimiter=";")
    assert "line 2, column 'ax_g'" in str(info.value) and "--units accel=" in str(info.value)


def test_a_bad_cell_is_named_by_line_and_column(tmp_path):
    logger_csv(tmp_path / "log.csv")
    lines = (tmp_path / "log.csv").read_text().splitlines()
    lines[300] = lines[300].replace(";31.5", ";warm")
    cells = lines[120].split(";")
    cells[5] = "x"
    lines[120] = ";".join(cells)
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(SessionFormatError) as info:
        import_csv(tmp_path / "log.csv", {"gyro": ["wx", "wy", "wz"]}, units={}, time_column="stamp_ms",
                   time_unit="ms", delimiter=";", temp_column="temp")
    assert (info.value.line, info.value.column) == (121, "wy") and "'x' is not a number" in str(info.value)


def test_time_that_runs_backwards_is_refused(tmp_path):
    logger_csv(tmp_path / "log.csv")
    lines = (tmp_path / "log.csv").read_text().splitlines()
    lines[50], lines[51] = lines[51], lines[50]
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(SessionFormatError) as info:
        import_csv(tmp_path / "log.csv", {"gyro": ["wx", "wy", "wz"]}, units={}, time_column="stamp_ms",
                   time_unit="ms", delimiter=";")
    assert (info.value.line, info.value.column) == (52, "stamp_ms")


@pytest.mark.parametrize("sections, words", [
    ({"x_p": {"start": 0, "end": 99999}}, "within the 10376 rows"),
    ({"x_q": {"start": 0, "end": 10}}, "not a Ferraris section"),
    ({"x_p": {"start": 20, "end": 10}}, "integer start < end"),
])
def test_a_bad_section_list_is_named(tmp_path, sections, words):
    (tmp_path / "s.json").write_text(json.dumps(sections))
    with pytest.raises(SessionFormatError, match=words) as info:
        import_ferraris(rate_hz=102.4, units={"accel": "m/s^2", "gyro": "deg/s"},
                        csv=FERRARIS / "example_ferraris_session.csv", sections=tmp_path / "s.json")
    assert Path(info.value.file).name == "s.json"


def test_the_command_writes_a_session_and_refuses_to_overwrite_it(tmp_path):
    args = [*RIG, "import", "ferraris", "--annotated", str(FERRARIS / "annotated_session.csv"), "--rate-hz", "204.8",
            "--out", str(tmp_path / "s")]
    first = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert first.returncode == 0, first.stderr
    assert "x_rot: +360 deg about +x" in first.stdout
    again = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert again.returncode == 2 and "--force" in again.stderr and "Traceback" not in again.stderr
    missing = subprocess.run([*RIG, "import", "imu_tk", "--accel", str(tmp_path / "nope.txt"), "--gyro",
                              str(XSENS / "xsens_gyro.mat"), "--out", str(tmp_path / "x")],
                             capture_output=True, text=True, timeout=120)
    assert missing.returncode == 2 and "nope.txt" in missing.stderr and "no such file" in missing.stderr
