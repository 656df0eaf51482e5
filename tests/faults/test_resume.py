"""A session stopped anywhere (SIGKILL, a stop signal) and finished with `rig resume` is as good as its
uninterrupted twin: no hold lost or twice, no move stored twice or integrated across the clock gap."""

from __future__ import annotations

import sqlite3
import statistics

import numpy as np
import pytest
from stopping import READS_PER_STEP, Killed, h_errors, stopping_factory

from fixtures.simrig import SimulatedHardware
from procedures.orchestrator import RigSpec, SessionOrchestrator
from rig.clock import SimClock
from rig.config import load_config
from rig.pipeline.screening import move_gap, resume_times
from rig.store import SESSION_FILE, SessionStore

N = 12          # orientations: enough for every sensor, short enough for a test
# (seed, gyro read at which the first run stops, how): in a move, in a hold, just after a hold was committed
CASES = [(11, 4 * READS_PER_STEP + 560, "kill"), (12, 7 * READS_PER_STEP + 250, "SIGINT"),
         (13, 2 * READS_PER_STEP + 502, "SIGTERM")]


def config():
    cfg = load_config()
    cfg.schedule.orientations = N
    return cfg


def run_interrupted(folder, seed, at_read, how):
    try:
        first = SessionOrchestrator(folder, stopping_factory(at_read, how)).start(config(), RigSpec(True, seed))
    except Killed:
        first = None
    return first, SessionOrchestrator(folder, stopping_factory()).resume()


@pytest.fixture(scope="module")
def twins(tmp_path_factory):
    root = tmp_path_factory.mktemp("twins")
    out = []
    for seed, at_read, how in CASES:
        SessionOrchestrator(root / f"twin-{seed}", stopping_factory()).start(config(), RigSpec(True, seed))
        first, resumed = run_interrupted(root / f"cut-{seed}", seed, at_read, how)
        out.append((seed, how, first, resumed, root / f"twin-{seed}", root / f"cut-{seed}"))
    return out


def test_the_first_run_ends_as_it_was_stopped(twins):
    for seed, how, first, _, _, cut in twins:
        if how == "kill":
            assert first is None
        else:
            assert first.status == "aborted" and first.signum is not None
            assert how in first.reason and first.holds > 0


def test_every_resumed_session_completes_with_each_hold_once_and_no_move_stored_twice(twins):
    for seed, _, _, resumed, _, cut in twins:
        assert resumed.status == "complete" and resumed.verdict == "PASS", resumed.reason
        with SessionStore.open(cut) as store:
            data = store.to_session_data()
            assert store.status[0] == "complete"
            assert len(store.resume_times()) == 1
        assert [j for j, _ in data.hold_rows()] == list(range(N))
        db = sqlite3.connect(cut / SESSION_FILE)
        moves = [s for (s,) in db.execute("SELECT step FROM segment WHERE phase = 'move' ORDER BY id")]
        assert sorted(moves) == list(range(N - 1)), seed          # every move once in the file
        db.close()


def test_no_move_is_integrated_across_the_resume(twins):
    for _, _, _, _, _, cut in twins:
        with SessionStore.open(cut) as store:
            data = store.to_session_data()
            (t_resume,) = store.resume_times()
        assert resume_times(data) == [t_resume]
        streams = data.moves("gyro")
        assert len(streams) == N - 1
        for m in streams:
            assert not (m.t[0] < t_resume <= m.t[-1])
            assert np.diff(m.t).max() < 0.05                      # sampled throughout, no hole


def test_h_errors_of_resumed_sessions_match_their_twins(twins):
    ratios = {}
    for seed, _, _, _, twin, cut in twins:
        e_twin, e_cut = h_errors(twin), h_errors(cut)
        for sensor in e_twin:
            ratios.setdefault(sensor, []).append((e_cut[sensor], e_twin[sensor]))
    gyro = [cut / twin for cut, twin in ratios["gyro"]]
    assert max(gyro) <= 1.5, gyro
    assert statistics.median(gyro) <= 1.1, gyro
    for sensor in ("accel", "mag"):        # noise-limited: as good as the twin, or as a typical twin
        typical = statistics.median(twin for _, twin in ratios[sensor])
        for cut, twin in ratios[sensor]:
            assert cut <= max(1.5 * twin, typical), (sensor, cut, twin)


def test_a_session_stopped_before_its_first_hold_resumes_from_the_start(tmp_path):
    first, resumed = run_interrupted(tmp_path / "s", 5, 100, "kill")
    assert first is None and resumed.status == "complete"
    with SessionStore.open(tmp_path / "s") as store:
        data = store.to_session_data()
    assert [j for j, _ in data.hold_rows()] == list(range(N))


def test_a_session_stopped_while_calibrating_is_finished_without_the_rig(tmp_path, monkeypatch):
    import procedures.orchestrator

    def killed(*a, **k):
        raise Killed()

    monkeypatch.setattr(procedures.orchestrator, "calibrate_session", killed)
    with pytest.raises(Killed):
        SessionOrchestrator(tmp_path / "s", stopping_factory()).start(config(), RigSpec(True, 6))
    monkeypatch.undo()

    def no_rig(config, spec):
        raise AssertionError("every hold is recorded: resuming must not build the rig")

    outcome = SessionOrchestrator(tmp_path / "s", no_rig).resume()
    assert outcome.status == "complete" and (tmp_path / "s" / "calibration.json").exists()


def test_a_hole_or_a_resume_inside_a_move_keeps_it_out_of_the_gyro_calibration(tmp_path):
    """Sessions resumed before the rig held again at the last orientation (or any recording with a hole in a
    move) have a move spanning the clock gap: the pipeline does not integrate it, and says so."""
    from rig.pipeline import calibrate_session

    SessionOrchestrator(tmp_path / "s", stopping_factory()).start(config(), RigSpec(True, 7))
    with SessionStore.open(tmp_path / "s") as store:
        data = store.to_session_data()
    m = data.moves("gyro")[4]
    assert move_gap(m, []) is None
    later = data.t > m.t[len(m.t) // 2]
    data.t = np.where(later, data.t + 2.5, data.t)                 # a 2.5 s hole in the middle of move 4
    result = calibrate_session(data, settle_s=0.0)
    assert any("move 4 -> 5 not used" in w and "no samples for 2.5" in w for w in result.warnings), result.warnings
    data.meta["resumes"] = [{"t_s": float(m.t[len(m.t) // 2 + 1]) + 2.5}]
    result = calibrate_session(data, settle_s=0.0)
    assert any("move 4 -> 5 not used" in w and "spans the resume" in w for w in result.warnings), result.warnings


def test_a_resumed_run_draws_new_noise_and_a_run_repeats_its_own():
    """A resumed run is a new process: restarting the noise stream would give the holds after the interruption
    the noise of the first holds, errors shared between two orientations that no real sensor has."""
    def first_samples(run):
        hw = SimulatedHardware(config(), SimClock(), seed=5, run=run)
        samples = np.array([hw.world.sense_one("gyro", 0.01 * k) for k in range(50)])
        return samples - samples.mean(axis=0)             # the table is still: what is left is the noise

    assert np.array_equal(first_samples(0), first_samples(0))
    assert np.array_equal(first_samples(1), first_samples(1))
    correlation = np.corrcoef(first_samples(0).ravel(), first_samples(1).ravel())[0, 1]
    assert abs(correlation) < 0.5
