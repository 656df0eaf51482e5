"""The twin of a still log (one pose held: an Allan-variance run, a unit left on the bench): its statistics, in
the units it was recorded in, against replicas of white noise; blind to a clean log, it names a hidden walk of the
bias or a coarse step at their sizes, and it runs from the command line on a real MPU-6050 log."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_unseen_recordings import rig  # noqa: E402

from fixtures.world.recorded import HeldAttitude, RecordedAttitude  # noqa: E402
from procedures.twin.analysis import analyse_twin  # noqa: E402
from procedures.twin.motion import ReplayedAttitude  # noqa: E402
from procedures.twin.draws import drawn_level, noise_dof  # noqa: E402
from procedures.twin.replay import reconstruct  # noqa: E402
from procedures.twin.replicas import replica  # noqa: E402
from rig.errors import CalibrationError  # noqa: E402
from rig.io.recording import recording_session  # noqa: E402
from rig.noise.still import sample_noise  # noqa: E402
from rig.noise.still_log import still_log_calibration  # noqa: E402

RATE_HZ = 100.0
COUNTS_PER_G = 2048.0
DATA = Path(__file__).resolve().parents[1] / "data" / "mpu6050-tomisuarez2"


def still_log(seed: int, *, seconds: float = 120.0, accel_step: int = 1, gyro_walk: float = 0.0):
    """A unit left still, as a logger writes it: the accelerometer in counts (2048 per g, 3 counts of white noise)
    rounded to `accel_step` counts; the gyroscope in counts (2 counts of white noise) on a bias that walks at
    `gyro_walk` counts per sqrt(s) on every axis."""
    rng = np.random.default_rng(seed)
    n = int(seconds * RATE_HZ)
    accel = np.array([20.0, -41.0, COUNTS_PER_G]) + rng.normal(0.0, 3.0, (n, 3))
    accel = np.round(accel / accel_step) * accel_step
    walk = np.cumsum(rng.normal(0.0, gyro_walk / np.sqrt(RATE_HZ), (n, 3)), axis=0)
    gyro = np.round(np.array([-30.0, 12.0, 5.0]) + walk + rng.normal(0.0, 2.0, (n, 3)))
    return recording_session(np.arange(n) / RATE_HZ, {"accel": accel, "gyro": gyro},
                             units={"accel": "counts", "gyro": "counts"}, source=f"<still log {seed}>",
                             sample_rate_hz=RATE_HZ)


def named(report: dict) -> dict[tuple[str, str], dict]:
    return {(c["effect"], c["sensor"]): c for c in report["causes"]}


def test_a_still_log_of_white_noise_is_inside_its_twin_and_nothing_is_named():
    report = analyse_twin(still_log(1))
    s = report["summary"]
    assert "still log" in report["replayed"]
    assert s["inside_before"] >= 0.9 * s["statistics"], s["outside_before"]
    assert report["causes"] == []
    # one pose: its mean is what the twin's response was made from, so no statistic of the means is compared
    assert not [n for n in report["statistics"] if "hold_mean" in n or "norm_residual" in n or "scatter" in n]


def test_a_walk_of_the_gyro_bias_is_named_a_rate_random_walk_in_counts_at_its_size():
    """K = 0.3 counts per sqrt(s): the Allan deviation rises as K sqrt(tau / 3) above the white noise's from a few
    seconds on. The gyro is in counts, which no scale turns into deg/s: its magnitude is reported in counts."""
    report = analyse_twin(still_log(2, gyro_walk=0.3))
    causes = named(report)
    walk = causes.get(("rate_random_walk", "gyro"))
    assert walk is not None, sorted(causes)
    assert walk["unit"] == "counts per sqrt(s)"
    assert 0.15 < walk["magnitude"] < 0.6, walk["magnitude"]
    assert not [c for c in causes if c[1] == "accel"], sorted(causes)
    s = report["summary"]
    assert s["inside_after"] >= 0.9 * s["statistics"] > s["inside_before"], s


@pytest.mark.parametrize("size", [4, 8])
def test_a_coarse_step_of_the_accelerometer_is_named_quantisation_at_its_size(size):
    """Counts that come in steps of 4 or 8 under 3 counts of noise (the MPU-6050's accelerometer does so under 54):
    the step, in m/s^2 at the scale the log's own mean gives (g), and the replicas with it take the log's steps back.
    A step of 8 is more than twice the noise: the noise ahead of the rounding is found from where the log's mean sits
    on the grid (x at 20 counts, halfway between two levels; y at -41, near one)."""
    report = analyse_twin(still_log(3, accel_step=size))
    step = named(report).get(("quantisation", "accel"))
    assert step is not None, sorted(named(report))
    expected = size * 9.80665 / np.linalg.norm([20.0, -41.0, COUNTS_PER_G])
    assert abs(step["magnitude"] - expected) < 0.02 * step["magnitude"]
    assert step["unit"] == "m/s^2"
    assert np.allclose(step["params"]["noise_ahead_of_rounding_raw"], 3.0, rtol=0.08), step["params"]
    s = report["summary"]
    assert {f"accel.step.{axis}" for axis in "xyz"} <= set(s["outside_before"]) - set(s["outside_after"])
    assert s["inside_after"] >= 0.9 * s["statistics"], s


def test_a_real_still_log_runs_from_the_command_line(tmp_path):
    """tomisuarez2's MPU-6050 left still for 7.5 minutes (PROVENANCE.md): imported and analysed as a user would.
    Every statistic that stays outside its band is listed as unexplained, and the extension brings at least 90 %
    inside."""
    done = rig("import", "csv", str(DATA / "example_data_tinit_calc.csv"), "--header-line", "5", "--rate-hz", "100",
               "--accel", "ax,ay,az", "--gyro", "gx,gy,gz", "--out", str(tmp_path / "log"))
    assert done.returncode == 0, done.stderr
    done = rig("discrepancy", str(tmp_path / "log"), "--json", str(tmp_path / "d.json"))
    assert done.returncode == 0, done.stderr
    assert "one pose held (a still log)" in done.stdout and "Traceback" not in done.stderr
    twin = json.loads((tmp_path / "d.json").read_text())["twin"]
    s = twin["summary"]
    assert s["inside_after"] >= 0.9 * s["statistics"], s
    assert sorted(twin["unexplained"]) == sorted(s["outside_after"])
    assert all(c["unit"].startswith("counts") for c in twin["causes"] if c["sensor"] == "gyro")


def test_a_still_log_too_short_or_with_a_stuck_axis_is_refused_with_what_is_wrong():
    short = still_log(4, seconds=0.06)
    with pytest.raises(CalibrationError, match="a still log of 6 samples; its twin needs at least 8"):
        still_log_calibration(short)
    stuck = still_log(5, seconds=10.0)
    stuck.raw["gyro"][:, 2] = 7.0
    with pytest.raises(CalibrationError, match=r"gyro\.z .* holds the same value 7 on all 1000 rows"):
        analyse_twin(stuck)


def test_a_still_log_is_replayed_at_one_attitude_and_senses_as_if_replayed_per_sample():
    """The replay of one pose held keeps one attitude, not one per sample (memory a 6-hour log cannot spare), and
    its replicas are, bit for bit, those the per-sample replay of the same attitude and a zero rate gives."""
    log = still_log(5, seconds=30.0)
    replay = reconstruct(log, still_log_calibration(log))
    assert isinstance(replay.attitude, HeldAttitude)
    n = len(replay.t)
    R = np.broadcast_to(replay.attitude.R, (n, 3, 3))
    per_sample = dataclasses.replace(replay, attitude=ReplayedAttitude(RecordedAttitude(replay.t, R, np.zeros((n, 3))),
                                                                       replay.t))
    for seed in (0, 7):
        held, each = replica(replay, seed), replica(per_sample, seed)
        for sensor in ("accel", "gyro"):
            assert np.array_equal(held.raw[sensor], each.raw[sensor])
    accel = replica(replay, 0).raw["accel"].mean(axis=0)
    assert abs(np.linalg.norm(accel) - np.linalg.norm(log.raw["accel"].mean(axis=0))) < 1.0    # counts, 1 g = 2048


def test_the_replicas_level_scatters_as_a_still_logs_own_estimate_of_it():
    """A still log's white level is its sample-to-sample noise, whose consecutive differences share a sample: the
    replicas' level, drawn from what the log allows it to be, must scatter as that estimate does, not as the spread's
    (a third less)."""
    log = still_log(8, seconds=50.0)
    n = len(log.t)
    dof = noise_dof(log, "gyro", still_log_calibration(log))
    drawn = np.array([drawn_level(np.ones(3), dof, seed, 0) for seed in range(3000)])[:, 0]
    rng = np.random.default_rng(9)
    own = np.array([sample_noise(rng.normal(0.0, 1.0, n)) for _ in range(3000)])
    assert abs(np.std(drawn) / np.std(own) - 1.0) < 0.1, (np.std(drawn), np.std(own))
