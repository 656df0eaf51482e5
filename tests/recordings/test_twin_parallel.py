"""The twin's shortcuts give what the plain computation gives: replicas in one pool or in several, on one core or
two; the held-out refits in a forked process or in place; the attitude evaluated once; distinct values counted
without a sort; three spectra in one Welch call."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ferraris_synth import generate  # noqa: E402

from procedures.twin.motion import align, attitudes  # noqa: E402
from procedures.twin.replay import reconstruct, twin_view  # noqa: E402
from procedures.twin.replicas import Background, ReplicaJob, replica_runs, replica_statistics  # noqa: E402
from rig.calibration.recordings.recording import calibrate_recording  # noqa: E402
from rig.errors import CalibrationError  # noqa: E402
from rig.noise.statistics import _distinct, band_powers  # noqa: E402
from rig.rotations import matrix_from_rotvec  # noqa: E402


@pytest.fixture(scope="module")
def replay():
    session, _ = generate(5, face_s=4.0)
    rec = calibrate_recording(session)
    view = twin_view(session, rec)
    return reconstruct(view, calibrate_recording(view))


def test_replicas_do_not_depend_on_the_pool_they_ran_in(replay):
    together = replica_runs([ReplicaJob(replay, [0, 1, 2]), ReplicaJob(replay, [7, 1])], workers=2)
    apart = [replica_statistics(replay, [0, 1, 2], workers=1), replica_statistics(replay, [7, 1], workers=1)]
    assert together == apart
    assert together[0][0][1] == together[1][0][1]          # seed 1 in either job: the same replica
    assert together[0][0][0] != together[0][0][1]


def _square(x):
    return x * x


def _refuse(x):
    raise CalibrationError(f"cannot use {x}")


def test_background_gives_the_result_or_raises_the_error_here():
    with Background(_square, 7) as job:
        assert job.result() == 49
    with Background(_refuse, 3) as job, pytest.raises(CalibrationError, match="cannot use 3"):
        job.result()


def test_the_attitude_evaluated_once_is_the_recorded_one_and_read_only(replay):
    recorded = replay.attitude.recorded
    for t in (replay.t, replay.t - 0.003, replay.t[::7]):
        for a, b in zip(replay.attitude.attitude(t), recorded.attitude(t)):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    for a in replay.attitude.attitude(replay.t):
        with pytest.raises(ValueError, match="read-only"):
            a[:] = 0.0
    np.testing.assert_allclose(replay.attitude.attitude(replay.t)[0], recorded.attitude(replay.t)[0], rtol=0, atol=1e-12)


def test_attitudes_are_the_sample_by_sample_product():
    rng = np.random.default_rng(3)
    n = 400
    t = np.cumsum(rng.uniform(0.009, 0.011, n))
    omega = rng.normal(0.0, 0.5, (n, 3))
    pose_of = np.full(n, -1)
    pose_of[:50], pose_of[120:200], pose_of[260:261], pose_of[300:380] = 0, 1, 2, 0
    up = [v / np.linalg.norm(v) for v in rng.normal(size=(3, 3))]
    for shift in (0, 60):                        # starting in a pose, and in a motion
        expected = np.empty((n - shift, 3, 3))
        p, tt, w = pose_of[shift:], t[shift:], omega[shift:]
        current = align(np.eye(3), up[p[0]] if p[0] >= 0 else np.array([0.0, 0.0, 1.0]))
        for i in range(len(tt)):
            if p[i] >= 0 and (i == 0 or p[i - 1] != p[i]):
                current = align(current, up[p[i]])
            elif i > 0 and p[i] < 0:
                current = current @ matrix_from_rotvec(0.5 * (w[i - 1] + w[i]) * (tt[i] - tt[i - 1]))
            expected[i] = current
        # a product of n rotations, each exact to a few ulps: the order of the sums inside a matrix product is the
        # BLAS kernel's, so the two agree to about n ulps, not bit for bit
        np.testing.assert_allclose(attitudes(tt, w, p, up), expected, rtol=0, atol=8 * len(tt) * np.finfo(float).eps)


@pytest.mark.parametrize("values", [
    np.round(np.random.default_rng(1).normal(0, 40, 5000)),                       # counts
    np.round(np.random.default_rng(2).normal(0, 40, 5000)) * 0.06,                # a quantum in SI units
    np.random.default_rng(3).normal(0, 1, 5000),                                  # no quantum
    np.array([-3.0, 2e9, 5.0, 5.0, np.nan, np.inf, -3.0, 7.0]),                   # whole numbers, wide range
    np.array([np.nan, np.nan]),
])
def test_distinct_values_are_numpys(values):
    u, n = _distinct(values)
    expected_u, expected_n = np.unique(values[np.isfinite(values)], return_counts=True)
    assert np.array_equal(u, expected_u) and np.array_equal(n, expected_n)


def test_three_spectra_in_one_call_are_each_one():
    x = np.random.default_rng(4).normal(size=(1500, 3)) * [1.0, 3.0, 0.1]
    together = band_powers(x.T, 100.0)
    for k in range(3):
        alone = band_powers(x[:, k], 100.0)
        assert list(alone) == list(together)
        assert all(alone[band] == together[band][k] for band in alone)


def test_the_bands_of_white_noise_hold_its_one_sided_level():
    x = np.random.default_rng(4).normal(0.0, 3.0, 60_000)
    powers = band_powers(x, 100.0)
    assert len(powers) == 4
    for power in powers.values():
        assert abs(power / (2 * 3.0 ** 2 / 100.0) - 1) < 0.1