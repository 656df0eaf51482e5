"""imu_tk ASCII reader on the real Xsens test data and on broken files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rig.errors import SessionFormatError
from rig.io.imu_tk import read_imu_tk
from tests.paths import DATA

DATA = DATA / "imu_tk-xsens"


@pytest.fixture(scope="module")
def xsens():
    return read_imu_tk(DATA / "xsens_acc.mat"), read_imu_tk(DATA / "xsens_gyro.mat")


def test_real_xsens_files_shape_and_time(xsens):
    (t_a, acc), (t_g, gyr) = xsens
    assert t_a.shape == (51175,) and acc.shape == (51175, 3) and gyr.shape == (51175, 3)
    assert t_a[0] == pytest.approx(0.02984) and t_a[-1] == pytest.approx(511.718)
    np.testing.assert_array_equal(t_a, t_g)
    assert np.median(np.diff(t_a)) == pytest.approx(0.01, abs=2e-4)


def test_real_xsens_column_ranges_match_provenance(xsens):
    (_, acc), (_, gyr) = xsens
    np.testing.assert_array_equal(acc.min(axis=0), [27465, 28782, 26922])
    np.testing.assert_array_equal(acc.max(axis=0), [38626, 38330, 40115])
    np.testing.assert_array_equal(gyr.min(axis=0), [1306, 856, 9676])
    np.testing.assert_array_equal(gyr.max(axis=0), [64485, 65352, 62912])


def test_first_row_exact(xsens):
    (t, acc), _ = xsens
    assert t[0] == 0.02984
    np.testing.assert_array_equal(acc[0], [33108, 33329, 36429])


def test_commas_comments_and_blank_lines(tmp_path):
    p = tmp_path / "a.txt"
    p.write_text("# t x y z\n0.0, 1, 2, 3\n\n0.01,4,5,6\n  0.02 7 8 9\n")
    t, xyz = read_imu_tk(p)
    np.testing.assert_array_equal(t, [0.0, 0.01, 0.02])
    np.testing.assert_array_equal(xyz, [[1, 2, 3], [4, 5, 6], [7, 8, 9]])


@pytest.mark.parametrize("bad_line, line, column, words", [
    ("0.02 7 8", 3, "z", "3 values, expected 4"),
    ("0.02 7 8 9 10", 3, None, "5 values"),
    ("0.02 7 abc 9", 3, "y", "'abc' is not a number"),
    ("nan 7 8 9", 3, "timestamp", "not a finite number"),
    ("0.005 7 8 9", 3, "timestamp", "not after the previous"),
])
def test_errors_name_file_line_column(tmp_path, bad_line, line, column, words):
    p = tmp_path / "bad.txt"
    p.write_text(f"0.0 1 2 3\n0.01 4 5 6\n{bad_line}\n0.03 1 1 1\n")
    with pytest.raises(SessionFormatError) as info:
        read_imu_tk(p)
    err = info.value
    assert (Path(err.file).name, err.line, err.column) == ("bad.txt", line, column)
    assert words in str(err)


def test_line_numbers_count_comments(tmp_path):
    p = tmp_path / "bad.txt"
    p.write_text("# header\n\n0.0 1 2 3\n0.01 4 x 6\n")
    with pytest.raises(SessionFormatError) as info:
        read_imu_tk(p)
    assert (info.value.line, info.value.column) == (4, "y")


def test_missing_and_empty_file(tmp_path):
    with pytest.raises(SessionFormatError, match="no such file"):
        read_imu_tk(tmp_path / "none.txt")
    (tmp_path / "e.txt").write_text("# nothing\n")
    with pytest.raises(SessionFormatError, match="no data rows"):
        read_imu_tk(tmp_path / "e.txt")
