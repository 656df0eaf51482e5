"""`rig calibrate --sim` end to end, a hard kill and resume, export and recalibration from the export."""

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

RIG = [sys.executable, "-m", "rig.cli"]


def run(*args, check=True, **kw):
    return subprocess.run([*RIG, *args], capture_output=True, text=True, check=check, timeout=300, **kw)


def rel_err(cal: dict, truth: dict, name: str) -> tuple[float, float]:
    H, Ht = np.array(cal["sensors"][name]["H"]), np.array(truth["sensors"][name]["H"])
    B, Bt = np.array(cal["sensors"][name]["B"]), np.array(truth["sensors"][name]["B"])
    return np.linalg.norm(H - Ht) / np.linalg.norm(Ht), np.linalg.norm(B - Bt) / np.linalg.norm(Bt)


@pytest.fixture(scope="module")
def sim_session(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "unit"
    proc = run("calibrate", "--sim", "--seed", "7", "--no-progress", "--out", str(out))
    return out, proc


def test_sim_calibration_writes_calibration_truth_and_report(sim_session):
    out, proc = sim_session
    cal = json.loads((out / "calibration.json").read_text())
    truth = json.loads((out / "truth.json").read_text())
    assert cal["schema"] == "rig-calibration/1"
    for name in ("accel", "gyro", "mag"):
        eH, eB = rel_err(cal, truth, name)
        assert eH < 5e-3, (name, eH)               # well inside the scale/misalignment errors simulated (~3 %)
        assert np.linalg.det(np.array(cal["sensors"][name]["H"])) > 0
    assert (out / "report.md").exists()
    assert "H error" in proc.stdout


def test_sim_session_store_is_complete(sim_session):
    out, _ = sim_session
    from rig.store import SessionStore

    store = SessionStore.open(out)
    assert store.status[0] == "complete"
    assert store.completed_holds() == list(range(20))
    assert store.metadata["truth"]["sensors"]["accel"]["H"]


def test_export_then_calibrate_from_gives_the_same_calibration(sim_session, tmp_path):
    out, _ = sim_session
    run("export", str(out), "--to", str(tmp_path / "exported"))
    run("calibrate", "--from", str(tmp_path / "exported"), "--settle-s", "0", "--out", str(tmp_path / "again"))
    a = json.loads((out / "calibration.json").read_text())
    b = json.loads((tmp_path / "again" / "calibration.json").read_text())
    for name in ("accel", "gyro", "mag"):
        np.testing.assert_allclose(b["sensors"][name]["H"], a["sensors"][name]["H"], rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(b["sensors"][name]["B"], a["sensors"][name]["B"], rtol=1e-6, atol=1e-9)


def _holds_in_file(folder: Path) -> int:
    con = sqlite3.connect(folder / "session.sqlite")
    try:
        return con.execute("SELECT COUNT(DISTINCT step) FROM segment WHERE phase = 'hold'").fetchone()[0]
    except sqlite3.Error:
        return 0
    finally:
        con.close()


def test_sigkill_mid_session_then_resume_completes_without_loss_or_duplicates(tmp_path):
    out = tmp_path / "killed"
    proc = subprocess.Popen([*RIG, "calibrate", "--sim", "--seed", "3", "--no-progress", "--time-scale", "40",
                             "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not ((out / "session.sqlite").exists() and _holds_in_file(out) >= 6):
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    from rig.store import SessionStore

    before = SessionStore.open(out).completed_holds()
    assert 6 <= len(before) < 20
    assert before == list(range(len(before)))
    res = run("resume", str(out), "--no-progress")
    store = SessionStore.open(out)
    assert store.status[0] == "complete", res.stdout + res.stderr
    assert store.completed_holds() == list(range(20))
    session = store.to_session_data()
    steps = [j for j, _ in session.hold_rows()]
    assert steps == list(range(20))                     # each hold once, in order
    assert (out / "calibration.json").exists()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_stop_signal_marks_the_session_aborted_by_that_signal_and_exits_128_plus_it(tmp_path, sig):
    out = tmp_path / "interrupted"
    proc = subprocess.Popen([*RIG, "calibrate", "--sim", "--no-progress", "--time-scale", "40", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not ((out / "session.sqlite").exists() and _holds_in_file(out) >= 2):
        time.sleep(0.05)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, err
    from rig.store import SessionStore

    status, reason = SessionStore.open(out).status
    assert status == "aborted"
    assert signal.Signals(sig).name in reason
    assert "rig resume" in err and "Traceback" not in err


def test_repeatability_reports_the_spread_of_every_element(tmp_path):
    out = tmp_path / "rep"
    run("repeatability", "--sim", "--trials", "2", "--orientations", "12", "--out", str(out))
    cals = [json.loads((out / f"trial-00{k}" / "calibration.json").read_text()) for k in (1, 2)]
    truths = [json.loads((out / f"trial-00{k}" / "truth.json").read_text()) for k in (1, 2)]
    assert truths[0]["sensors"] == truths[1]["sensors"]             # the same simulated unit
    assert cals[0]["sensors"]["accel"]["B"] != cals[1]["sensors"]["accel"]["B"]   # new noise each trial
    data = json.loads((out / "repeatability.json").read_text())
    b0 = [c["sensors"]["gyro"]["B"][0] for c in cals]
    h11 = [c["sensors"]["accel"]["H"][1][1] for c in cals]
    gyro, accel = data["sensors"]["gyro"], data["sensors"]["accel"]
    assert gyro["mean"][gyro["elements"].index("B[0]")] == pytest.approx(np.mean(b0), rel=1e-9)
    assert gyro["std"][gyro["elements"].index("B[0]")] == pytest.approx(np.std(b0, ddof=1), rel=1e-6)
    assert accel["mean"][accel["elements"].index("H[1,1]")] == pytest.approx(np.mean(h11), rel=1e-9)
    assert (out / "repeatability.md").exists() and (out / "repeatability_gyro.png").exists()



def test_the_same_seed_reproduces_the_session_and_another_seed_is_another_unit(sim_session, tmp_path):
    out, _ = sim_session
    run("calibrate", "--sim", "--seed", "7", "--no-progress", "--out", str(tmp_path / "again"))
    run("calibrate", "--sim", "--seed", "8", "--no-progress", "--orientations", "10", "--out", str(tmp_path / "other"))
    a, b = (json.loads((p / "calibration.json").read_text())["sensors"] for p in (out, tmp_path / "again"))
    assert a == b
    assert json.loads((out / "truth.json").read_text()) == json.loads((tmp_path / "again" / "truth.json").read_text())
    other = json.loads((tmp_path / "other" / "truth.json").read_text())
    assert other["sensors"]["accel"]["B"] != json.loads((out / "truth.json").read_text())["sensors"]["accel"]["B"]
