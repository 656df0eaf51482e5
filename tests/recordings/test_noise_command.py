"""`rig noise DIR`: a static log's Allan deviation and noise terms, from the command line as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rig.io.recording import recording_session
from rig.io.session_writer import write_session

RIG = [sys.executable, "-m", "rig.cli"]
RATE_HZ = 100.0


def test_a_static_log_gives_back_the_white_noise_and_the_rate_random_walk_it_was_made_with(tmp_path):
    """20 minutes of a still unit: a gyro of white noise N = 0.2 counts/sqrt(Hz) (2 counts a sample, rounded) on a
    bias that walks at K = 0.05 counts sqrt(Hz) (ruling the Allan deviation from 7 s on), an accelerometer of white
    noise alone (0.003 m/s^2 a sample); the terms come back at their sizes (within five stated deviations:
    test_noise_terms.py says why five), and the accelerometer's walk and floor are said not determinable, not
    fitted (weighted by allantools' own error, which counts overlapping pairs as independent, the fit once found
    walks in white noise)."""
    rng = np.random.default_rng(3)
    n = int(20 * 60 * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    walk = np.cumsum(rng.normal(0.0, 0.05 / np.sqrt(RATE_HZ), (n, 3)), axis=0)
    gyro = np.round(np.array([5.0, -3.0, 1.0]) + walk + rng.normal(0.0, 2.0, (n, 3)))
    accel = np.array([0.02, -0.01, 9.81]) + rng.normal(0.0, 0.003, (n, 3))
    session = recording_session(t, {"accel": accel, "gyro": gyro}, units={"accel": "m/s^2", "gyro": "counts"},
                                source="<static log>", sample_rate_hz=RATE_HZ)
    folder = write_session(session, tmp_path / "log")
    done = subprocess.run([*RIG, "noise", str(folder), "--json", str(tmp_path / "n.json")], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "gyro.x: white noise" in done.stdout and "Traceback" not in done.stderr
    assert "accel.x: white noise" in done.stdout and "not determinable from 1200 s" in done.stdout
    report = json.loads((tmp_path / "n.json").read_text())
    assert report["analysed"]["what"] == "the whole recording" and report["effects"] == []
    white_rounded = np.sqrt(4.0 + 1 / 12) / np.sqrt(RATE_HZ)          # rounding adds 1/12 count^2 a sample
    for axis in "xyz":
        gyro_fit, accel_fit = report["sensors"]["gyro"][axis], report["sensors"]["accel"][axis]
        assert abs(gyro_fit["K"] - 0.05) <= 5 * gyro_fit["K_std"], (gyro_fit["K"], gyro_fit["K_std"])
        assert abs(gyro_fit["N"] - white_rounded) <= 5 * gyro_fit["N_std"], gyro_fit["N"]
        assert abs(accel_fit["N"] - 0.0003) <= 5 * accel_fit["N_std"], accel_fit["N"]
        assert accel_fit["K"] is None and accel_fit["terms"]["K"]["status"] == "not determinable"
        assert accel_fit["B"] is None and accel_fit["terms"]["B"]["status"] == "not determinable"
        assert gyro_fit["tau_s"][0] == 1 / RATE_HZ and gyro_fit["tau_s"][-1] <= n / RATE_HZ / 3


def test_a_folder_that_is_not_a_session_is_named_in_one_line(tmp_path):
    (tmp_path / "meta.json").write_text("{}")
    done = subprocess.run([*RIG, "noise", str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr


def test_a_recording_that_moves_is_refused_not_given_an_allan_deviation(tmp_path):
    """Six faces and three turns: the Allan deviation of the motion would be read as noise terms."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from ferraris_synth import generate

    session, _ = generate(8)
    folder = write_session(session, tmp_path / "moving")
    done = subprocess.run([*RIG, "noise", str(folder)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, (done.returncode, done.stderr)
    assert "is not still" in done.stderr and "Traceback" not in done.stderr


def counts_log(seconds: float, seed: int, mag_warm_up: float = 0.0, tau_s: float = 15.0):
    """A still unit in counts (accelerometer 3, gyroscope and magnetometer 2 counts of white noise a sample); the
    magnetometer's x drifting by `mag_warm_up` counts as it warms up (y and z by -0.3 and 0.15 of it)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    accel = np.round(np.array([20.0, -41.0, 2048.0]) + rng.normal(0.0, 3.0, (n, 3)))
    gyro = np.round(np.array([-30.0, 12.0, 5.0]) + rng.normal(0.0, 2.0, (n, 3)))
    mag = np.round(np.array([300.0, -120.0, 400.0]) + rng.normal(0.0, 2.0, (n, 3))
                   + np.outer(np.exp(-t / tau_s), np.array([1.0, -0.3, 0.15]) * mag_warm_up))
    return recording_session(t, {"accel": accel, "gyro": gyro, "mag": mag},
                             units={"accel": "counts", "gyro": "counts", "mag": "counts"}, source="<counts log>",
                             sample_rate_hz=RATE_HZ, field_uT=50.0)


def test_a_magnetometer_warming_up_is_named_and_its_noise_read_after_it(tmp_path):
    """A magnetometer drifting 200 counts in its first minute (tau 15 s) of a 10-minute still log: the drift is
    named a warm-up with its a and tau, the magnetometer is analysed from where it has settled, and no bias
    instability or rate random walk is reported for it; kept in (--keep-warm-up), it is read as one."""
    folder = write_session(counts_log(600, 4, mag_warm_up=200.0), tmp_path / "log")
    done = subprocess.run([*RIG, "noise", str(folder), "--json", str(tmp_path / "n.json")], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "mag.x: warm-up (warm_up): a = " in done.stdout and "after its warm-up" in done.stdout, done.stdout
    report = json.loads((tmp_path / "n.json").read_text())
    found = {(e["sensor"], e["axis"]): e for e in report["effects"]}
    assert {e["effect"] for e in found.values()} == {"warm_up"} and {s for s, _ in found} == {"mag"}
    x = found[("mag", "x")]
    assert x["unit"] == "counts" and abs(x["params"]["a"] - 200.0) <= 5 * x["params"]["a_std"], x
    assert abs(x["params"]["tau_s"] - 15.0) <= 5 * x["params"]["tau_s_std"], x
    span = report["spans"]["mag"]
    assert span["after_warm_up"] and span["start_s"] >= 3 * 15.0
    assert not report["spans"]["gyro"]["after_warm_up"] and report["spans"]["gyro"]["start_s"] == 0.0
    for axis, fit in report["sensors"]["mag"].items():
        assert fit["B"] is None and fit["K"] is None, (axis, fit["terms"])

    kept = subprocess.run([*RIG, "noise", str(folder), "--keep-warm-up", "--json", str(tmp_path / "k.json")],
                          capture_output=True, text=True, timeout=120)
    assert kept.returncode == 0, kept.stderr
    assert "analysed with it, its drift in the terms" in kept.stdout
    fit = json.loads((tmp_path / "k.json").read_text())["sensors"]["mag"]["x"]
    assert fit["K"] is not None or fit["B"] is not None, fit["terms"]


def test_a_log_that_was_bumped_is_refused_with_where_and_its_still_parts_are_analysed_on_request(tmp_path):
    """A still log bumped at 200-203 s and left in a slightly other pose: refused, naming when it moved and the
    options that analyse part of it; --window still analyses the longest still stretch (after the bump), and
    --start/--end the part before it."""
    log = counts_log(600, 5)
    rows = (log.t >= 200) & (log.t < 203)
    shake = np.sin(2 * np.pi * 4 * log.t[rows])[:, None]
    log.raw["accel"][rows] += np.round(300 * shake)
    log.raw["gyro"][rows] += np.round(500 * shake)
    log.raw["accel"][log.t >= 203] += [40.0, 0.0, -1.0]
    folder = write_session(log, tmp_path / "log")
    refused = subprocess.run([*RIG, "noise", str(folder)], capture_output=True, text=True, timeout=120)
    assert refused.returncode == 2, refused.stderr
    message = refused.stderr.strip()
    assert "Traceback" not in message and len(message.splitlines()) == 1, message
    assert "is not still: it moves at 200.0-20" in message and "--window still" in message, message

    done = subprocess.run([*RIG, "noise", str(folder), "--window", "still", "--json", str(tmp_path / "s.json")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    analysed = json.loads((tmp_path / "s.json").read_text())["analysed"]
    assert analysed["window"] == "still" and 203.0 <= analysed["start_s"] <= 206.0 and analysed["end_s"] > 599.0
    assert "the longest still stretch" in done.stdout

    done = subprocess.run([*RIG, "noise", str(folder), "--start", "10", "--end", "190", "--json",
                           str(tmp_path / "p.json")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "p.json").read_text())
    assert abs(report["analysed"]["start_s"] - 10.0) < 0.02 and abs(report["analysed"]["end_s"] - 190.0) < 0.02
    assert report["sensors"]["gyro"]["x"]["tau_s"][-1] <= 180.0 / 3


@pytest.mark.parametrize("args,words", [(["--start", "700"], "--start 700 s: the recording runs from 0 to"),
                                        (["--start", "30", "--end", "20"], "--end 20 s: it must be after the start"),
                                        (["--end", "900"], "within the recording's"),
                                        (["--start", "10.001", "--end", "10.002"], "0 samples from 10.001 to 10.002 s")])
def test_a_part_outside_the_recording_is_refused_naming_the_option(tmp_path, args, words):
    folder = write_session(counts_log(60, 6), tmp_path / "log")
    done = subprocess.run([*RIG, "noise", str(folder), *args], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and words in done.stderr, done.stderr
    assert "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1


def test_a_real_still_log_gives_its_white_noise_and_says_what_its_length_cannot(tmp_path):
    """tomisuarez2's MPU-6050 left still for 7.5 minutes (PROVENANCE.md), imported as a user would."""
    data = Path(__file__).resolve().parents[1] / "data" / "mpu6050-tomisuarez2"
    done = subprocess.run([*RIG, "import", "csv", str(data / "example_data_tinit_calc.csv"), "--header-line", "5",
                           "--rate-hz", "100", "--accel", "ax,ay,az", "--gyro", "gx,gy,gz", "--out",
                           str(tmp_path / "log")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    done = subprocess.run([*RIG, "noise", str(tmp_path / "log"), "--json", str(tmp_path / "n.json")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "n.json").read_text())
    for sensor, axes in report["sensors"].items():
        for axis, fit in axes.items():
            assert fit["terms"]["N"]["status"] == "fitted" and fit["N"] > 0, (sensor, axis)
            for key in "QBK":
                term = fit["terms"][key]
                assert (term["status"] == "fitted") == (fit[key] is not None) and term["bound"] > 0
