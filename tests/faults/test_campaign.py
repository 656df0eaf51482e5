"""The fault campaign's small version (benchmarks/fault_campaign.py, docs/guides/interruptions.md): one simulated
session per fault kind, that fault alone, run as an operator would (`rig calibrate --sim` in a subprocess, killed
from outside, resumed), against the campaign's targets."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

import fault_campaign  # noqa: E402


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Five noise trials per unit: against the worst of two, an unharmed session's fresh noise passes 1.5x in
    about 1.5 % of comparisons, and a run makes 33 of them."""
    root = tmp_path_factory.mktemp("campaign")
    return fault_campaign.run_campaign(sessions=0, units=2, orientations=9, seed=16, time_scale=100.0, workers=2,
                                       twin_trials=5, root=root, disk_ways=("fsize",), one_each=True)


def test_every_fault_kind_is_run(campaign):
    kinds = [r["draw"]["kinds"] for r in campaign["sessions"]]
    assert sorted(k for (k,) in kinds) == sorted(fault_campaign.KINDS)
    fired = {f["kind"] for r in campaign["sessions"] for f in r["faults"]}
    timed = {"modbus_exception", "turntable_restart", "i2c_nack", "adxrs453_parity", "adxrs453_fault",
             "chip_reset", "bump", "disk_full"}
    assert timed <= fired, timed - fired
    killed = [run for r in campaign["sessions"] if r["draw"]["kills"] for run in r["runs"] if run["signal"]]
    assert killed, "the kill never landed"


def test_nothing_lost_nothing_twice_no_traceback(campaign):
    s = campaign["summary"]
    assert s["holds_lost"] == 0 and s["holds_duplicated"] == 0 and s["tracebacks"] == 0, s


def test_every_exit_code_is_truthful_and_every_failure_is_a_fault_it_names(campaign):
    s = campaign["summary"]
    assert s["exit_codes_untruthful"] == [] and s["unexplained_failures"] == [], s
    assert s["faults_neither_survived_nor_reported"] == [], s["faults_neither_survived_nor_reported"]


def test_every_session_completes_and_its_h_errors_stay_within_the_noise(campaign):
    s = campaign["summary"]
    assert s["not_completed"] == [], s["not_completed"]
    assert s["beyond_1.5x_worst_noise_trial"] == [], s["beyond_1.5x_worst_noise_trial"]
