"""Faults of the sensor board in a session (found by the fault campaign): a chip that resets to its power-on
registers is configured again and its step redone, I2C NACK bursts leave empty cells and a sensor that stays
silent ends the session with its name, late ticks never stamp two reads a moment apart, and a hold that keeps
moving is a fault of the rig (exit 3), not a bug (exit 70)."""

from __future__ import annotations

import numpy as np
import pytest
from stopping import h_errors

from procedures.acquisition import Sampler
from procedures.orchestrator import RigSpec, SessionOrchestrator
from rig.assembly import build_rig
from rig.clock import SimClock
from rig.config import load_config
from rig.store import SessionStore
from rig.store.assemble import used_segments

N = 9


def config(board="bsn", **faults):
    cfg = load_config()
    cfg.board = board
    cfg.schedule.orientations = N
    if faults:
        cfg.sim = {"faults": faults}
    return cfg


def run(folder, cfg, seed=2):
    return SessionOrchestrator(folder, build_rig).start(cfg, RigSpec(True, seed))


def built_from(folder):
    with SessionStore.open(folder) as store:
        segments = [(phase, step) for _, phase, step in used_segments(store._db)]
        moves = [s for (s,) in store._db.execute("SELECT step FROM segment WHERE phase = 'move'")]
        events = [(e["kind"], e["message"]) for e in store.events()]
    return segments, moves, events


@pytest.fixture(scope="module")
def twins(tmp_path_factory):
    """Per board, the worst H error of three fault-free sessions of the unit with different noise trials: the
    gyro's varies by 2x between trials at 9 orientations, so a faulted session is held to that band."""
    root = tmp_path_factory.mktemp("twins")
    out = {}
    for board in ("bsn", "wearable"):
        for trial in range(3):
            folder = root / f"{board}-{trial}"
            assert SessionOrchestrator(folder, build_rig).start(config(board), RigSpec(True, 2, None, trial)).status \
                == "complete"
            errors = h_errors(folder)
            out[board] = {s: max(e, out.get(board, {}).get(s, 0.0)) for s, e in errors.items()}
    return out


@pytest.mark.parametrize("board, part, at", [("bsn", "gyro", [25.0]), ("bsn", "mag", [20.0, 40.0]),
                                             ("wearable", "accel", [30.0])])
def test_a_chip_reset_mid_session_is_configured_again_and_its_step_redone(tmp_path, twins, board, part, at):
    outcome = run(tmp_path / "s", config(board, chip_reset_part=part, chip_reset_at_s=at))
    assert outcome.status == "complete", outcome.reason
    assert not [w for w in outcome.warnings if "not used" in w], outcome.warnings
    assert any("step(s) redone" in w for w in outcome.warnings), outcome.warnings
    segments, moves, events = built_from(tmp_path / "s")
    redos = [message for kind, message in events if kind == "redo"]
    assert len(redos) == len(at) and all("reads 0x" in m and "configured again" in m for m in redos), redos
    assert sorted(moves) == list(range(N - 1))                      # the spoiled move was never stored
    steps = [s for phase, s in segments if phase == "move"]
    assert steps == list(range(N - 1))
    holds = [s for phase, s in segments if phase == "hold"]
    assert sorted(set(holds)) == list(range(N)) and len(holds) == N + len(at)   # each redone hold held again
    errors = h_errors(tmp_path / "s")
    for sensor, e in errors.items():
        assert e <= 1.5 * twins[board][sensor], (sensor, e, twins[board][sensor])


def test_a_chip_that_keeps_resetting_fails_the_session_naming_it(tmp_path):
    cfg = config(chip_reset_part="gyro", chip_reset_at_s=[20.0 + 2.0 * k for k in range(40)])
    outcome = run(tmp_path / "s", cfg)
    assert outcome.status == "failed" and outcome.error_log is None, outcome.reason
    assert "ITG-3200" in outcome.reason and "keeps resetting" in outcome.reason


def test_an_i2c_nack_burst_leaves_empty_cells_and_the_session_completes(tmp_path, twins):
    outcome = run(tmp_path / "s", config(i2c_nack_part="mag", i2c_nack_at_s=[20.0, 33.0], i2c_nack_s=0.08))
    assert outcome.status == "complete", outcome.reason
    _, _, events = built_from(tmp_path / "s")
    errors = [m for kind, m in events if kind == "read-error"]
    assert errors and all("HMC5843 at I2C address 0x1E" in m and "no ACK" in m for m in errors)
    assert any("read error(s)" in w for w in outcome.warnings)


def test_a_sensor_silent_for_a_second_ends_the_session_naming_it(tmp_path):
    outcome = run(tmp_path / "s", config(i2c_nack_part="gyro", i2c_nack_at_s=[20.0], i2c_nack_s=2.0))
    assert outcome.status == "failed" and outcome.error_log is None, outcome.reason
    assert "ITG-3200 at I2C address 0x68" in outcome.reason and "no valid sample for 1.0" in outcome.reason
    assert 0 < outcome.holds < N


def test_a_hold_that_keeps_moving_is_a_fault_of_the_rig_not_a_bug(tmp_path, monkeypatch):
    import procedures.move_and_hold

    monkeypatch.setattr(procedures.move_and_hold, "hold_has_motion", lambda rec, rate_hz: "gyro x: knocked")
    outcome = run(tmp_path / "s", config())
    assert outcome.status == "failed" and outcome.error_log is None
    assert "hold 0 kept moving in all 3 attempts" in outcome.reason


class CountingBoard:
    """One triad that returns its read count; no data-ready flag, no aux."""

    def __init__(self):
        self.n = 0
        self.triads = {"gyro": self}
        self.parts = []

    def read_raw(self):
        self.n += 1
        return (self.n, 0, 0)

    def read_temperature(self):
        return None

    def read_supply(self):
        return None


@pytest.mark.parametrize("late", [0.5, 0.7, 0.95, 0.999999999, 1.0, 2.3, 3.0 - 1e-12])
def test_a_late_tick_never_comes_a_moment_before_the_next(late):
    """A table request retried inside a move (clock.sleep of its backoff) makes the sampler late; the next two
    stamps must still be at least half a period apart (they were 1e-15 s apart: the gyro calibration refused
    the session)."""
    clock = SimClock()
    sampler = Sampler(CountingBoard(), clock, rate_hz=100.0)
    sampler.run(3)                                   # the clock is at the third tick; the next is due one period on
    clock.sleep((1.0 + late) * sampler.dt)
    sampler.run(3)
    t = sampler.take().t
    assert np.diff(t).min() >= sampler.dt / 2 - 1e-12, np.diff(t)


def test_a_gap_in_the_gyro_during_a_move_redoes_the_step(tmp_path, twins):
    """An I2C NACK burst on the gyro while the table turns (a retried table request does the same): the step is
    redone, so the gyro calibration keeps every move whole."""
    outcome = run(tmp_path / "s", config(i2c_nack_part="gyro", i2c_nack_at_s=[7.3], i2c_nack_s=0.06))
    assert outcome.status == "complete", outcome.reason
    assert not [w for w in outcome.warnings if "not used" in w], outcome.warnings
    segments, moves, events = built_from(tmp_path / "s")
    redos = [m for kind, m in events if kind == "redo"]
    assert len(redos) == 1 and "the gyro has no samples for" in redos[0] and "step 1 redone from hold 0" in redos[0]
    assert sorted(moves) == list(range(N - 1))
    for sensor, e in h_errors(tmp_path / "s").items():
        assert e <= 1.5 * twins["bsn"][sensor], (sensor, e, twins["bsn"][sensor])


def test_a_move_whose_first_gyro_samples_are_missing_is_not_integrated(tmp_path):
    """The gyro silent from the end of a hold into the start of the move: the stream would begin with the table
    already turning (its first degrees never integrated); the pipeline does not use that move, and says why."""
    from rig.pipeline import calibrate_session

    assert run(tmp_path / "s", config()).status == "complete"
    with SessionStore.open(tmp_path / "s") as store:
        data = store.to_session_data()
    holds = dict(data.hold_rows())
    end_of_hold = data.t[holds[3][-1]]
    gone = (data.t > end_of_hold - 0.03) & (data.t < end_of_hold + 0.25)
    data.raw["gyro"][gone] = np.nan
    result = calibrate_session(data, settle_s=0.0)
    assert any("move 3 -> 4 not used: it has no samples for 0.2" in w for w in result.warnings), result.warnings
