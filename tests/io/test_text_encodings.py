"""Files that are not UTF-8 (a Latin-1 degree sign from a logger, UTF-16 from PowerShell's `>`): every reader names
the file, the line and the byte, and the commands exit 2 (bad input) without a traceback. Before, a byte past the
first few kilobytes of samples.csv, or any in meta.json, reached `rig discrepancy` and `rig noise` as an internal
error (exit 70) and `rig calibrate --from` as "cannot be calibrated" (exit 3)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from io_synthetic import build_session

from rig.errors import SessionFormatError
from rig.io.calibration_json import CalibrationFileError, read_calibration, write_calibration
from rig.io.session_csv import read_session
from rig.io.session_writer import write_session
from rig.calibration.numerics.result import TriadCalibration

RIG = [sys.executable, "-m", "rig.cli"]


@pytest.fixture(scope="module")
def session():
    s, _ = build_session(seed=5, hold_s=2.0, schedule_deg=np.array([[0, 0], [90, 0], [90, 90], [180, 45]]))
    return s


@pytest.fixture
def folder(tmp_path, session) -> Path:
    return write_session(session, tmp_path / "s")


def put_byte(path: Path, line: int, byte: bytes) -> None:
    lines = path.read_bytes().split(b"\n")
    lines[line - 1] += byte
    path.write_bytes(b"\n".join(lines))


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*RIG, *args], capture_output=True, text=True, timeout=300)


def test_a_latin1_byte_deep_in_samples_is_named_by_line(folder, tmp_path):
    samples = folder / "samples.csv"
    line = samples.read_bytes().count(b"\n") - 1                 # far past the decoder's first chunk
    assert samples.stat().st_size > 64 * 1024
    put_byte(samples, line, b"\xb0")
    with pytest.raises(SessionFormatError) as info:
        read_session(folder)
    assert info.value.line == line and "byte 0xb0" in str(info.value)
    for args in (["noise", str(folder)], ["discrepancy", str(folder), "--json", str(tmp_path / "d.json")],
                 ["calibrate", "--from", str(folder), "--out", str(tmp_path / "c"), "--no-progress"]):
        done = run(*args)
        assert done.returncode == 2, (args, done.stderr)
        assert f"samples.csv, line {line}: not UTF-8 text: byte 0xb0" in done.stderr
        assert "Traceback" not in done.stderr + done.stdout


def test_meta_in_utf16_is_named_and_a_utf8_byte_order_mark_is_read(folder):
    meta = folder / "meta.json"
    text = meta.read_text(encoding="utf-8")
    meta.write_bytes(text.encode("utf-16"))
    with pytest.raises(SessionFormatError, match=r"meta\.json, line 1: UTF-16 text"):
        read_session(folder)
    meta.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    assert read_session(folder).meta["format"] == json.loads(text)["format"]


def test_a_calibration_file_that_is_not_utf8_is_bad_input_naming_its_line(tmp_path):
    triad = TriadCalibration(H=np.eye(3), B=np.zeros(3), method="test")
    path = write_calibration(tmp_path / "calibration.json", {"accel": triad}, gravity=9.80665, field_uT=None)
    put_byte(path, 3, b"\xe9")
    with pytest.raises(CalibrationFileError, match=r"line 3: not UTF-8 text: byte 0xe9") as info:
        read_calibration(path)
    assert isinstance(info.value, ValueError)


def test_a_configuration_that_is_not_utf8_is_named_by_line(tmp_path):
    config = tmp_path / "rig.toml"
    config.write_bytes(b"# r\xe9glage du banc\n")
    done = run("plan", "--config", str(config))
    assert done.returncode == 2, done.stderr
    assert "rig.toml, line 1: cannot read rig configuration: not UTF-8 text: byte 0xe9 at character 4" in done.stderr
