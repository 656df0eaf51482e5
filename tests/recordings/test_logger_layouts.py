"""Loggers that write their settings above the columns, start with a rest shorter than imu_tk's 50 s, or hold
fewer poses than imu_tk asks for, as tomisuarez2/ImuCalibration's MPU-6050 session does (a preamble of four lines,
a 36.5 s rest, ten poses): each was refused before the calibration could look at the data; the rest is now found in
the data."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_unseen_recordings import COLUMNS, SI, imported, one_clear_line, recording, rig, write_csv  # noqa: E402

PREAMBLE = "Fs,100\nLogging Type,0\nInitialization time,30\nWaiting time,3\n"


def with_preamble(path: Path) -> Path:
    path.write_text(PREAMBLE + path.read_text())
    return path


def test_a_header_below_the_loggers_settings_is_found_by_line_and_errors_name_the_files_own_lines(tmp_path):
    rec = recording(2, poses=3, rest_s=5.0)
    csv = with_preamble(write_csv(tmp_path / "log.csv", rec))
    done = rig("import", "csv", str(csv), *COLUMNS, *SI, "--out", str(tmp_path / "a"))
    assert done.returncode == 2, done.stdout
    assert "line 1" in one_clear_line(done) and "give --header-line 5" in done.stderr, done.stderr
    folder = imported(tmp_path, csv, "--header-line", "5")
    meta = json.loads((folder / "meta.json").read_text())
    assert meta["imported"]["header_line"] == 5
    lines = csv.read_text().splitlines()
    lines[41] = lines[41].replace(",", ",x", 1)                   # the file's line 42: its 37th row of data
    csv.write_text("\n".join(lines) + "\n")
    done = rig("import", "csv", str(csv), *COLUMNS, *SI, "--header-line", "5", "--out", str(tmp_path / "b"))
    assert done.returncode == 2 and "line 42" in one_clear_line(done), done.stderr


def test_a_file_without_a_header_is_read_by_column_number_and_its_rows_named_by_their_lines(tmp_path):
    """mikoff/imu-calib's MPU-9150 logs are plain numbers separated by blanks, no header, no time column."""
    rec = recording(3, poses=3, rest_s=5.0)
    plain = tmp_path / "imu.log"
    np.savetxt(plain, np.column_stack([rec["accel"], rec["gyro"]]), fmt="%.6f", delimiter=" ")
    by_number = ["--rate-hz", "50", "--accel", "1,2,3", "--gyro", "4,5,6", *SI, "--delimiter", " "]
    done = rig("import", "csv", str(plain), *by_number, "--out", str(tmp_path / "a"))
    assert done.returncode == 2 and "give --header-line 0" in one_clear_line(done), done.stderr
    done = rig("import", "csv", str(plain), *by_number[:-1], ",", "--header-line", "0", "--out", str(tmp_path / "w"))
    assert done.returncode == 2 and "line 1, column '2'" in one_clear_line(done), done.stderr
    assert "its first line has 1 cell separated by ','" in done.stderr, done.stderr
    done = rig("import", "csv", str(plain), *by_number, "--header-line", "0", "--out", str(tmp_path / "b"))
    assert done.returncode == 0, done.stderr
    samples = np.genfromtxt(tmp_path / "b" / "samples.csv", delimiter=",", names=True)
    assert len(samples) == len(rec["t"])
    np.testing.assert_allclose(samples["ax"], np.round(rec["accel"][:, 0], 6), atol=1e-9)
    np.testing.assert_allclose(samples["gz"], np.round(rec["gyro"][:, 2], 6), atol=1e-9)
    lines = plain.read_text().splitlines()
    lines[36] += " 1.0"                                             # the file's line 37: its 37th row
    plain.write_text("\n".join(lines) + "\n")
    done = rig("import", "csv", str(plain), *by_number, "--header-line", "0", "--out", str(tmp_path / "c"))
    assert done.returncode == 2 and "line 37" in one_clear_line(done), done.stderr
    assert "the first row has 6" in done.stderr, done.stderr


def test_a_recording_whose_rest_is_shorter_than_imu_tks_is_calibrated_from_the_rest_its_data_show(tmp_path):
    """A 30 s rest, where imu_tk's 50 s threshold window would take in the first poses and motions: the rest is
    found in the data (no option), and a rest said at import (kept in meta.json) overrides it; both calibrate, the
    said one's gyro bias is the mean of its 30 s, and the two agree within the deviations they state."""
    rec = recording(4, rate=100.0, poses=14, rest_s=30.0)
    csv = write_csv(tmp_path / "log.csv", rec)
    plain = imported(tmp_path / "plain", csv)
    assert "initial_rest_s" not in json.loads((plain / "meta.json").read_text())
    done = rig("calibrate", "--from", str(plain), "--out", str(tmp_path / "c1"), "--no-progress")
    assert done.returncode == 0, done.stderr
    found = json.loads((tmp_path / "c1" / "calibration.json").read_text())["sensors"]
    assert found["accel"]["initial_rest"] == "found" and 28.5 < found["accel"]["initial_rest_s"] <= 30.0, found["accel"]
    assert "initial rest" in done.stdout and "found in the data" in done.stdout, done.stdout
    said = imported(tmp_path / "said", csv, "--initial-rest-s", "30")
    assert json.loads((said / "meta.json").read_text())["initial_rest_s"] == 30.0
    done = rig("calibrate", "--from", str(said), "--out", str(tmp_path / "c2"), "--no-progress")
    assert done.returncode == 0, done.stderr
    given = json.loads((tmp_path / "c2" / "calibration.json").read_text())["sensors"]
    assert given["accel"]["initial_rest"] == "given" and given["accel"]["initial_rest_s"] == 30.0
    gyro = given["gyro"]
    rest = rec["gyro"][rec["t"] < 30.0]
    assert np.allclose(gyro["B"], rest.mean(axis=0), atol=1e-9)
    H = np.array(gyro["H"])
    assert np.abs(np.linalg.svd(H @ np.linalg.inv(rec["Hg"]), compute_uv=False) - 1).max() < 0.01
    for sensor in ("accel", "gyro"):
        a, b = found[sensor], given[sensor]
        assert (np.abs(np.subtract(a["B"], b["B"])) <= 2 * np.array(b["B_std"])).all(), sensor
        assert (np.abs(np.subtract(a["H"], b["H"])) <= 2 * np.array(b["H_std"]) + 1e-12).all(), sensor


def test_ten_poses_are_calibrated_with_a_warning_and_nine_are_refused(tmp_path):
    """The accelerometer's nine unknowns and one pose to spare; imu_tk asks for twelve. Ten give its H within 1 %
    (the truth's H is within 1 % of I, so this could not pass by leaving H at a nominal start) and say how thin
    the fit is; nine are refused naming the count."""
    ten = imported(tmp_path / "ten", write_csv(tmp_path / "ten.csv", recording(6, rate=100.0, poses=10)))
    done = rig("calibrate", "--from", str(ten), "--out", str(tmp_path / "c10"), "--no-progress")
    assert done.returncode == 0, done.stderr
    assert "only 10 static intervals" in done.stdout, done.stdout
    rec = recording(6, rate=100.0, poses=10)
    accel = json.loads((tmp_path / "c10" / "calibration.json").read_text())["sensors"]["accel"]
    truth = rec["Ha"]
    assert np.abs(np.linalg.svd(np.array(accel["H"]) @ np.linalg.inv(truth), compute_uv=False) - 1).max() < 0.01
    nine = imported(tmp_path / "nine", write_csv(tmp_path / "nine.csv", recording(6, rate=100.0, poses=9)))
    done = rig("calibrate", "--from", str(nine), "--out", str(tmp_path / "c9"), "--no-progress")
    assert done.returncode == 3 and "fewer than 10 static intervals" in one_clear_line(done), done.stderr
