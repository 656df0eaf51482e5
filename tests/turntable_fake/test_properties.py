"""Property: any sequence of moves ends settled on the last accepted target; CMD_SEQ counts them.

Driven through `handle_request` (the same entry point the Modbus action uses) to run many cases fast.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from fixtures.turntable import FakeTurntable
from rig.clock import SimClock

BASE = 0x0100


def words(value: int) -> list[int]:
    raw = value & 0xFFFFFFFF
    return [raw >> 16, raw & 0xFFFF]


def s32(hi: int, lo: int) -> int:
    raw = (hi << 16) | lo
    return raw - (1 << 32) if raw >= 1 << 31 else raw


move = st.tuples(st.integers(-400_000, 400_000), st.integers(1_000, 200_000), st.integers(1_000, 500_000),
                 st.floats(0.0, 3.0))


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(move, min_size=1, max_size=5))
def test_moves_end_in_position_on_the_last_accepted_target(moves):
    clock = SimClock()
    tt = FakeTurntable(clock, settle_s=0.1)
    assert tt.handle_request(6, BASE, 1, [1]) == [1]
    last_target, accepted = 0, 0
    for target, speed, accel, wait in moves:
        tt.handle_request(16, BASE + 2, 6, words(target) + words(speed) + words(accel))
        reply = tt.handle_request(6, BASE + 1, 1, [1])
        if abs(target) <= 360_000:
            assert reply == [0]
            last_target, accepted = target, accepted + 1
        else:
            assert int(reply) == 3  # beyond the soft limit
        clock.sleep(wait)
        assert tt.handle_request(3, BASE + 0x1B, 1, None) == [accepted]
    clock.sleep(2 * 720 / 1.0 + 1.0)  # longer than any move at >= 1 deg/s, 1 deg/s^2
    regs = tt.handle_request(3, BASE + 0x10, 12, None)
    assert s32(regs[0], regs[1]) == last_target
    assert regs[8] & 0b111 == 0b101, "enabled, not moving, in position"
    assert regs[11] == accepted
