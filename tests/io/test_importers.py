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
from rig.io.recording import IMPORT_UNITS
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


MIKOFF = DATA / "mikoff-imu-calib"
SI = ["--units", "accel=m/s^2,gyro=rad/s", "--initial-rest-s", "7", "--gravity", "9.81"]


def imu_tk_files(folder: Path) -> tuple[Path, Path]:
    """mikoff's MPU-9150 log (m/s^2 and rad/s, 100 Hz, no time column: PROVENANCE.md) written in imu_tk's layout,
    `timestamp x y z` per sensor, its numbers as the logger printed them: an IMU logged in SI units."""
    rows = [line.split() for line in (MIKOFF / "imu0.log").read_text().splitlines() if line.strip()]
    accel, gyro = folder / "acc.txt", folder / "gyr.txt"
    accel.write_text("".join(f"{k / 100:.2f} {' '.join(r[:3])}\n" for k, r in enumerate(rows)))
    gyro.write_text("".join(f"{k / 100:.2f} {' '.join(r[3:])}\n" for k, r in enumerate(rows)))
    return accel, gyro


def test_an_imu_tk_file_in_si_units_imports_and_calibrates_as_the_same_log_read_as_csv(tmp_path):
    """The refusal of a file in SI units names --units, which every importer now takes: given as the message says,
    `rig import imu_tk` and `rig calibrate --format imu_tk` read the log, and the calibration is the one its CSV
    route makes (the route tests/recordings/test_mikoff_recording.py holds against its authors' method)."""
    accel, gyro = imu_tk_files(tmp_path)
    files = ["--accel", str(accel), "--gyro", str(gyro)]
    refused = subprocess.run([*RIG, "import", "imu_tk", *files, "--out", str(tmp_path / "x")], capture_output=True,
                             text=True, timeout=120)
    assert refused.returncode == 2 and "say so with --units accel=m/s^2" in refused.stderr, refused.stderr
    assert "acc.txt, line 1, column 'x'" in refused.stderr and not (tmp_path / "x").exists()

    done = subprocess.run([*RIG, "import", "imu_tk", *files, *SI, "--out", str(tmp_path / "x")], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    session = read_session(tmp_path / "x")
    assert session.meta["units"] == {"accel": "m/s^2", "gyro": "rad/s"} and session.meta["initial_rest_s"] == 7.0
    assert abs(np.median(np.linalg.norm(session.raw["accel"], axis=1)) - 9.81) < 0.2

    done = subprocess.run([*RIG, "calibrate", "--format", "imu_tk", *files, *SI, "--out", str(tmp_path / "tk"),
                           "--no-progress"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.stdout[-800:], done.stderr)
    for args in (["import", "csv", str(MIKOFF / "imu0.log"), "--header-line", "0", "--delimiter", " ", "--rate-hz",
                  "100", "--accel", "1,2,3", "--gyro", "4,5,6", *SI, "--out", str(tmp_path / "csv")],
                 ["calibrate", "--from", str(tmp_path / "csv"), "--out", str(tmp_path / "csv_cal"), "--no-progress"]):
        done = subprocess.run([*RIG, *args], capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, (args[:2], done.stdout[-800:], done.stderr)
    ours = json.loads((tmp_path / "tk" / "calibration.json").read_text())
    theirs = json.loads((tmp_path / "csv_cal" / "calibration.json").read_text())["sensors"]
    assert ours["source"]["units"] == {"accel": "m/s^2", "gyro": "rad/s"}
    assert set(ours["sensors"]) == set(theirs) == {"accel", "gyro"}
    # the gyro's B is the mean of the 7 s rest, known to its samples' spread over their square root
    rest = session.raw["gyro"][session.t < 7.0]
    B_std = {"accel": np.array(ours["sensors"]["accel"]["B_std"]), "gyro": rest.std(axis=0) / np.sqrt(len(rest))}
    for sensor, cal in ours["sensors"].items():
        H, H_std = np.array(cal["H"]), np.array(cal["H_std"])
        assert np.abs(np.diag(H) - 1).max() < 0.02, (sensor, np.diag(H))       # SI in, SI out: H near one
        assert (np.abs(H - np.array(theirs[sensor]["H"])) <= 0.01 * H_std).all(), sensor
        assert (np.abs(np.array(cal["B"]) - np.array(theirs[sensor]["B"])) <= 0.01 * B_std[sensor]).all(), sensor


def test_imu_tk_files_in_g_are_kept_in_m_per_s2_and_a_unit_for_a_file_not_read_is_refused(tmp_path):
    accel, gyro = tmp_path / "acc.txt", tmp_path / "gyr.txt"
    accel.write_text("".join(f"{0.01 * k:.2f} 0.01 -0.02 1.0\n" for k in range(20)))
    gyro.write_text("".join(f"{0.01 * k:.2f} 1 -2 3\n" for k in range(20)))
    session = import_imu_tk({"accel": accel, "gyro": gyro}, units={"accel": "g"})
    assert session.meta["units"] == {"accel": "m/s^2", "gyro": "counts"}
    assert np.allclose(session.raw["accel"][0], [0.0980665, -0.196133, 9.80665], rtol=1e-12)
    done = subprocess.run([*RIG, "import", "imu_tk", "--accel", str(accel), "--gyro", str(gyro), "--units",
                           "accel=g,mag=uT", "--out", str(tmp_path / "x")], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "--units names mag" in done.stderr and "Traceback" not in done.stderr


def test_every_importer_takes_the_one_units_option():
    """`rig import imu_tk|ferraris|csv` and `rig calibrate --format imu_tk` read --units from one definition."""
    import click

    from rig.cli import main

    ctx = click.Context(main)
    group = main.get_command(ctx, "import")
    commands = [group.get_command(ctx, name) for name in group.list_commands(ctx)] + [main.get_command(ctx, "calibrate")]
    options = [next((p for p in cmd.params if "--units" in p.opts), None) for cmd in commands]
    assert len(commands) == 4 and all(options), [cmd.name for cmd, o in zip(commands, options) if o is None]
    assert len({(o.help, o.metavar, o.default) for o in options}) == 1
    assert all(unit in options[0].help for units in IMPORT_UNITS.values() for unit in units)
