"""The calibration procedure on the simulated rig: bumped holds redone, the table always left safe."""

import numpy as np
import pytest

from fixtures.world.model import Bump
from rig.schedule import Orientation
from procedures.session import record
from rig.assembly import build_sim, truth_after_start
from rig.config import load_config
from rig.turntable.errors import MoveTimeout

SCHEDULE = [Orientation(10, 0), Orientation(80, 60), Orientation(150, -40), Orientation(60, 140),
            Orientation(120, -150), Orientation(30, -90)]


class MemoryStore:
    def __init__(self, on_move=None):
        self.holds, self.moves, self.events, self.on_move = {}, [], [], on_move

    def append_hold(self, step, **kw):
        self.holds[step] = kw

    def append_move(self, step, **kw):
        self.moves.append((step, kw))
        if self.on_move:
            self.on_move(step)

    def log_event(self, kind, message, t=None):
        self.events.append((kind, message))

    def redo(self, t, reason):
        if self.moves and self.moves[-1][0] + 1 not in self.holds:
            self.moves.pop()                # the move into the spoiled hold, never followed by its hold (as the
                                            # session store forgets its pending move; a move spoiled before it
                                            # was appended leaves nothing to forget)
        self.events.append(("redo", reason))


def sim_rig(board="bsn", seed=3):
    cfg = load_config()
    cfg.board = board
    return build_sim(cfg, seed=seed)


def assert_table_safe(rig):
    status = rig.table.status()
    for ax in status.axes:
        assert "ENABLED" not in ax.flags and "MOVING" not in ax.flags, ax.describe()


@pytest.mark.parametrize("board", ["bsn", "wearable"])
def test_session_records_every_hold_and_move_and_matches_the_truth(board):
    with sim_rig(board) as rig:
        rig.board.start()
        truth = truth_after_start(rig)
        store = MemoryStore()
        record(rig, store, SCHEDULE)
        assert_table_safe(rig)
    assert sorted(store.holds) == list(range(len(SCHEDULE)))
    assert [s for s, _ in store.moves] == list(range(len(SCHEDULE) - 1))
    for step, hold in store.holds.items():
        assert hold["t"].size == 500 and hold["attempt"] == 1
        np.testing.assert_allclose(hold["measured_deg"], (SCHEDULE[step].outer_deg, SCHEDULE[step].inner_deg),
                                   atol=0.01)
        for name, norm in (("accel", 9.80665), ("mag", 50.0)):
            y = hold["samples"][name]
            y = y[~np.isnan(y).any(axis=1)]
            H, B = np.array(truth["sensors"][name]["H"]), np.array(truth["sensors"][name]["B"])
            u = (y.mean(axis=0) - B) @ H.T
            R = rig.config.geometry.rotation(*hold["measured_deg"])
            assert np.linalg.norm(u) == pytest.approx(norm, rel=3e-3)
            if name == "accel":
                np.testing.assert_allclose(u, R.T @ [0, 0, 9.80665], atol=0.05)
    for _, move in store.moves:
        g = move["samples"]["gyro"]
        assert not np.isnan(g).any()                       # every tick of every move has a gyro sample
        assert np.allclose(np.diff(move["t"]), 0.01)


def test_a_bumped_hold_is_detected_and_its_step_redone():
    """The move into the bumped hold is recorded again from the previous hold held again, so the gyro keeps it."""
    with sim_rig() as rig:
        rig.board.start()
        bumped = []

        def bump_next_hold(step):
            if step == 1 and not bumped:                     # the move into hold 2 just ended
                bumped.append(step)
                rig.world.bumps.append(Bump(rig.clock.now() + 2.0, amplitude_deg=0.3))

        store = MemoryStore(on_move=bump_next_hold)
        record(rig, store, SCHEDULE[:4])
    kinds = [k for k, _ in store.events]
    assert kinds == ["hold-repeated", "redo"], store.events
    assert "hold 2" in store.events[0][1] and "step 2 redone from hold 1 held again" in store.events[1][1]
    assert store.holds[2]["attempt"] == 2 and store.holds[1]["attempt"] == 1
    assert [step for step, _ in store.moves] == [0, 1, 2]


def test_a_move_that_never_arrives_fails_with_the_table_stopped_and_disabled():
    with sim_rig() as rig:
        rig.board.start()
        store = MemoryStore(on_move=None)
        rig.fake_table.faults.never_arrive(axis=1)
        with pytest.raises(MoveTimeout):
            record(rig, store, SCHEDULE[:3])
        assert_table_safe(rig)
    assert list(store.holds) == [0]       # the inner axis was already at hold 0; the move to hold 1 failed


def test_a_hold_that_never_stops_moving_fails_after_three_attempts_and_stores_nothing_of_it():
    from procedures.move_and_hold import HoldFailed

    with sim_rig() as rig:
        rig.board.start()

        def keep_bumping(step):
            if step == 1:                                    # every time the move into hold 2 ends
                rig.world.bumps.append(Bump(rig.clock.now() + 2.0, amplitude_deg=0.3))

        store = MemoryStore(on_move=keep_bumping)
        with pytest.raises(HoldFailed, match="hold 2 kept moving in all 3 attempts"):
            record(rig, store, SCHEDULE[:4])
        assert_table_safe(rig)
    assert sorted(store.holds) == [0, 1]
    assert [k for k, _ in store.events] == ["hold-repeated", "redo", "hold-repeated", "redo", "hold-repeated"]
