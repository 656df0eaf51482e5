"""Truthful exits: the exit code says how a command ended (docs/reference/exit-codes.md), the terminal says it in one
line without a traceback, and the stored status matches."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest
from click.testing import CliRunner

from rig.cli import main
from rig.store import SessionStore

RIG = [sys.executable, "-m", "rig.cli"]


def rig(*args, **kw):
    return subprocess.run([*RIG, *args], capture_output=True, text=True, timeout=300, **kw)


def no_traceback(res):
    assert "Traceback" not in res.stdout + res.stderr, res.stderr


def tight_config(tmp_path: Path) -> Path:
    text = resources.files("rig.configs").joinpath("sim.toml").read_text()
    tight = text.replace("[limits.gyro]\nresidual_rms_max = 0.02", "[limits.gyro]\nresidual_rms_max = 0.00001")
    assert tight != text
    path = tmp_path / "tight.toml"
    path.write_text(tight)
    return path


def test_a_fail_verdict_exits_1_is_printed_and_stored_as_rejected(tmp_path):
    out = tmp_path / "s"
    res = rig("calibrate", "--sim", "--config", str(tight_config(tmp_path)), "--orientations", "9", "--no-progress",
              "--out", str(out))
    assert res.returncode == 1, res.stderr
    no_traceback(res)
    assert "verdict: FAIL" in res.stderr and "gyro residual_rms" in res.stderr
    with SessionStore.open(out) as store:
        status, reason = store.status
        assert status == "rejected" and "gyro residual_rms" in reason
        assert store.metadata["verdict"] == "FAIL"
    assert json.loads((out / "report.json").read_text())["verdict"] == "FAIL"
    assert json.loads((out / "calibration.json").read_text())["verdict"] == "FAIL"
    again = rig("resume", str(out), "--no-progress")
    assert again.returncode == 2 and "already finished" in again.stderr


def test_a_pass_exits_0_and_says_so_and_a_second_run_into_the_same_folder_is_refused(tmp_path):
    out = tmp_path / "s"
    res = rig("calibrate", "--sim", "--orientations", "9", "--no-progress", "--out", str(out))
    assert res.returncode == 0 and "verdict: PASS" in res.stdout, res.stderr
    events = SessionStore.open(out).events()
    twice = rig("calibrate", "--sim", "--orientations", "9", "--no-progress", "--out", str(out))
    assert twice.returncode == 2
    no_traceback(twice)
    assert "a session already exists" in twice.stderr and f"rig resume {out}" in twice.stderr
    assert SessionStore.open(out).events() == events


def test_an_out_folder_that_cannot_be_made_is_bad_input(tmp_path):
    (tmp_path / "file").write_text("x")
    res = rig("calibrate", "--sim", "--no-progress", "--out", str(tmp_path / "file" / "s"))
    assert res.returncode == 2
    no_traceback(res)
    assert "cannot create the session folder" in res.stderr and "Not a directory" in res.stderr


@pytest.mark.parametrize("args", [["--seed", "-1"], ["--time-scale", "0"], ["--time-scale", "nan"],
                                  ["--orientations", "3"]])
def test_out_of_range_options_are_bad_input(tmp_path, args):
    res = rig("calibrate", "--sim", "--no-progress", "--out", str(tmp_path / "s"), *args)
    assert res.returncode == 2, res.stderr
    no_traceback(res)
    assert not (tmp_path / "s").exists()


def test_an_unexpected_exception_is_one_line_and_a_traceback_file(tmp_path, monkeypatch):
    import rig.commands.calibrate as calibrate

    def broken(*a, **k):
        raise TypeError("unsupported operand")

    monkeypatch.setattr(calibrate, "run_session_to", broken)
    res = CliRunner().invoke(main, ["calibrate", "--sim", "--out", str(tmp_path / "s")])
    assert res.exit_code == 70
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "internal error" in lines[0] and "TypeError: unsupported operand" in lines[0]
    log = Path(lines[0].split("the traceback is in ")[1].split(" ")[0])
    assert "Traceback" in log.read_text() and "unsupported operand" in log.read_text()
    log.unlink()


def test_resume_while_the_table_is_unreachable_says_so_and_marks_the_session_failed(tmp_path, monkeypatch):
    from stopping import Killed, stopping_factory

    from procedures.orchestrator import RigSpec, SessionOrchestrator
    from rig.config import load_config
    from rig.turntable.errors import CommunicationError
    import rig.commands.common as common

    cfg = load_config()
    cfg.schedule.orientations = 9
    with pytest.raises(Killed):
        SessionOrchestrator(tmp_path / "s", stopping_factory(1500)).start(cfg, RigSpec(True, 1))

    def unreachable(config, spec):
        raise CommunicationError("tcp://10.0.0.9:502: no answer to FC03 after 4 attempts (timed out)")

    monkeypatch.setattr(common, "build_rig", unreachable)
    res = CliRunner().invoke(main, ["resume", str(tmp_path / "s"), "--no-progress"])
    assert res.exit_code == 3, res.output
    assert "no answer to FC03" in res.output and "Traceback" not in res.output
    status, reason = SessionStore.open(tmp_path / "s").status
    assert status == "failed" and "resume failed before recording" in reason


UNSHARE = shutil.which("unshare")


def in_private_mount(script: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """Run `script` (sh) where $M is a small private tmpfs; mounted in a user+mount namespace, so no root is
    needed and nothing outside sees it."""
    if UNSHARE is None:
        pytest.skip("needs unshare(1) (util-linux) to mount a private tmpfs")
    (tmp_path / "m").mkdir()
    return subprocess.run([UNSHARE, "--user", "--map-root-user", "--mount", "sh", "-ec", script],
                          capture_output=True, text=True, timeout=300,
                          env={**__import__("os").environ, "M": str(tmp_path / "m"), "OUT": str(tmp_path),
                               "RIG": " ".join(RIG)})


def test_a_full_disk_fails_the_session_truthfully_and_resume_finishes_it_once_there_is_room(tmp_path):
    res = in_private_mount("""
        mount -t tmpfs -o size=2m tmpfs "$M"
        set +e
        $RIG calibrate --sim --orientations 12 --no-progress --out "$M/s" > "$OUT/first.out" 2> "$OUT/first.err"
        echo $? > "$OUT/first.rc"
        cp -a "$M/s" "$OUT/after-full"
        mount -o remount,size=64m "$M"
        $RIG resume "$M/s" --no-progress > "$OUT/resume.out" 2> "$OUT/resume.err"
        echo $? > "$OUT/resume.rc"
        cp -a "$M/s" "$OUT/after-resume"
    """, tmp_path)
    assert res.returncode == 0, res.stderr
    first_err = (tmp_path / "first.err").read_text()
    assert (tmp_path / "first.rc").read_text().strip() == "3", first_err
    assert "disk is full" in first_err and "Traceback" not in first_err
    with SessionStore.open(tmp_path / "after-full") as store:
        status, reason = store.status
        kept = store.completed_holds()
    assert status == "failed" and "disk is full" in reason
    assert 0 < len(kept) < 12
    assert (tmp_path / "resume.rc").read_text().strip() == "0", (tmp_path / "resume.err").read_text()
    with SessionStore.open(tmp_path / "after-resume") as store:
        assert store.status[0] == "complete"
        assert [j for j, _ in store.to_session_data().hold_rows()] == list(range(12))


def test_an_out_folder_on_a_read_only_disk_is_bad_input(tmp_path):
    res = in_private_mount("""
        mount -t tmpfs -o size=1m,ro tmpfs "$M"
        set +e
        $RIG calibrate --sim --no-progress --out "$M/s" > "$OUT/o" 2> "$OUT/e"; echo $? > "$OUT/rc"
        mkdir -p "$OUT/w" && mount -t tmpfs -o size=1m tmpfs "$OUT/w" && mkdir "$OUT/w/s" && \
            mount -o remount,ro "$OUT/w"
        $RIG calibrate --sim --no-progress --out "$OUT/w/s" > "$OUT/o2" 2> "$OUT/e2"; echo $? > "$OUT/rc2"
    """, tmp_path)
    assert res.returncode == 0, res.stderr
    for rc, err in (("rc", "e"), ("rc2", "e2")):
        text = (tmp_path / err).read_text()
        assert (tmp_path / rc).read_text().strip() == "2", text
        assert "Traceback" not in text and ("Read-only file system" in text or "not writable" in text), text


def test_a_stop_signal_after_the_session_ended_is_noted_not_obeyed():
    """The exit code stays the stored end's: a SIGTERM racing a failed session's exit must not turn exit 3 into
    death by signal (the fault campaign found it)."""
    import os
    import signal

    from rig.commands.common import late_stop_signals

    with late_stop_signals() as late:
        before = signal.getsignal(signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGTERM)
    assert late == [signal.SIGTERM]
    assert signal.getsignal(signal.SIGTERM) is not before


def test_in_the_rig_process_a_late_stop_signal_stays_noted_until_it_exits(monkeypatch):
    """Between the end of the session's block and the process's exit, a SIGTERM with the handlers given back
    killed `rig` with -15 while the store said `failed` (the fault campaign, once in 325 runs)."""
    import os
    import signal

    from rig import exits
    from rig.commands.common import late_stop_signals

    before = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(exits, "process_ends_with_command", True)
    try:
        with late_stop_signals() as late:
            pass
        os.kill(os.getpid(), signal.SIGTERM)
        assert late == [signal.SIGTERM]
    finally:
        signal.signal(signal.SIGTERM, before)


def test_the_rig_process_and_a_test_runner_are_told_apart():
    from rig import exits

    assert not exits.process_ends_with_command
    code = "import sys; from rig import exits; from rig.cli import main\n" \
           "try:\n    main()\nexcept SystemExit:\n    print(exits.process_ends_with_command)"
    out = subprocess.run([sys.executable, "-c", code, "--help"], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip().endswith("True"), out
    CliRunner().invoke(main, ["--help"])
    assert not exits.process_ends_with_command


@pytest.mark.parametrize("stop, code", [("SIGTERM", 143), ("SIGHUP", 129), ("SIGINT", 130)])
def test_any_command_stopped_by_a_signal_ends_in_one_line_with_its_code(tmp_path, stop, code):
    """A command with no stop handling of its own (here `rig import csv`, blocked opening a pipe no logger writes
    yet) ends on SIGTERM and SIGHUP as on Ctrl-C: the signal's default death said nothing and skipped the
    command's clean-up (a half-written file's temporary was left in the session folder)."""
    import os
    import signal
    import time

    fifo = tmp_path / "log.csv"
    os.mkfifo(fifo)
    proc = subprocess.Popen([*RIG, "import", "csv", str(fifo), "--rate-hz", "100", "--accel", "ax,ay,az",
                             "--out", str(tmp_path / "out")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(3.0)                      # started, and blocked in opening the pipe
        assert proc.poll() is None, proc.communicate()
        proc.send_signal(getattr(signal, stop))
        _, err = proc.communicate(timeout=20)
        assert proc.returncode == code, err
        assert err.strip().splitlines()[-1] == "aborted" and "Traceback" not in err, err
    finally:
        if proc.poll() is None:
            proc.kill()
