"""Motion through the wire with a SimClock the test advances: profiles, IN_POSITION, modes, encoder."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fixtures.turntable import FakeTurntable, TurntableServer

from .conftest import (ENABLE, ENABLED, HOME, HOMED, HOMING, IN_POSITION, LIMIT_POS, MOVE_ABS, MOVE_REL,
                       MOVE_VEL, MOVING, SET_ZERO, SOFT_LIMIT_POS, STOP, Axis, connect)


def test_full_move_profile_and_in_position_semantics(tt, clock, ax0):
    """90 deg at 30 deg/s, 60 deg/s^2: 0.5 s ramps, 2.5 s cruise, arrival 3.5 s after the command."""
    ax0.write(ENABLE, 1)
    clock.sleep(0.5)
    assert ax0.feedback()["status"] & IN_POSITION, "holding the start position"
    ax0.profile(90_000, 30_000, 60_000)
    t_cmd = clock.now()
    ax0.command(MOVE_ABS)
    fb = ax0.feedback()
    assert fb["status"] & MOVING and not fb["status"] & IN_POSITION, "IN_POSITION cleared by the new move"
    assert fb["seq"] == 1
    clock.sleep(1.0)
    fb = ax0.feedback()
    assert fb["vel"] == 30_000 and fb["pos"] == pytest.approx(22_500, abs=1)
    positions = []
    while clock.now() < t_cmd + 3.4:
        clock.sleep(0.05)
        fb = ax0.feedback()
        positions.append(fb["pos"])
        assert 0 <= fb["vel"] <= 30_000
    assert np.all(np.diff(positions) >= 0), "monotonic"
    clock.advance_to(t_cmd + 3.5 + 1e-6)
    fb = ax0.feedback()
    assert fb["pos"] == 90_000 and fb["vel"] == 0 and not fb["status"] & MOVING
    assert not fb["status"] & IN_POSITION, "arrived but not yet settled"
    # the window (5 mdeg) is entered sqrt(2*0.005/60) s before arrival; settle is 0.2 s
    t_in = t_cmd + 3.5 - math.sqrt(2 * 0.005 / 60.0) + 0.2
    clock.advance_to(t_in - 0.005)
    assert not ax0.feedback()["status"] & IN_POSITION
    clock.advance_to(t_in + 0.005)
    assert ax0.feedback()["status"] & IN_POSITION


def test_register_feedback_is_the_physical_track_through_the_encoder(tt, clock, ax0, ax1):
    for ax, target in ((ax0, -135_000), (ax1, 200_000)):
        ax.write(ENABLE, 1)
        ax.profile(target, 45_000, 90_000)
        ax.command(MOVE_ABS)
    for _ in range(40):
        clock.sleep(0.137)
        physical = tt.track.angles(clock.now())[0] * 1000.0
        for i, ax in enumerate((ax0, ax1)):
            fb = ax.feedback()
            assert abs(fb["pos"] - physical[i]) <= 1.0
            assert fb["counts"] == round(physical[i] / 360_000 * 2 ** 20)
            assert fb["pos"] == round(tt.encoder_angles(clock.now())[i] * 1000)


def test_encoder_quantization_and_following_error(clock):
    tt = FakeTurntable(clock, encoder_counts_per_rev=3600, start_angles=(1.234, -0.26))
    with TurntableServer(tt) as srv:
        c = connect(srv)
        a0, a1 = Axis(c, 0), Axis(c, 1)
        f0, f1 = a0.feedback(), a1.feedback()
        c.close()
    assert (f0["counts"], f0["pos"], f0["ferr"]) == (12, 1200, 34)
    assert (f1["counts"], f1["pos"], f1["ferr"]) == (-3, -300, 40)
    np.testing.assert_allclose(tt.encoder_angles(clock.now()), [1.2, -0.3])


def test_move_rel_is_relative_to_the_commanded_target(ax0, clock):
    ax0.write(ENABLE, 1)
    ax0.profile(10_000, 20_000, 40_000)
    ax0.command(MOVE_REL)
    clock.sleep(0.3)  # still moving
    ax0.command(MOVE_REL)
    clock.sleep(3.0)
    fb = ax0.feedback()
    assert fb["pos"] == 20_000 and fb["seq"] == 2


def test_new_target_while_moving_is_reached(ax0, clock):
    ax0.write(ENABLE, 1)
    ax0.profile(100_000, 50_000, 100_000)
    ax0.command(MOVE_ABS)
    clock.sleep(1.0)
    ax0.profile(-20_000, 50_000, 100_000)
    ax0.command(MOVE_ABS)
    clock.sleep(5.0)
    assert ax0.feedback()["pos"] == -20_000


def test_rate_mode_then_stop_decelerates(ax1, clock):
    ax1.write(ENABLE, 1)
    ax1.profile(0, -20_000, 40_000, 10_000)
    ax1.command(MOVE_VEL)
    clock.sleep(1.0)
    fb = ax1.feedback()
    assert fb["vel"] == -20_000 and fb["status"] & MOVING and not fb["status"] & IN_POSITION
    pos_at_stop = fb["pos"]
    ax1.command(STOP)
    clock.sleep(1.0)
    fb = ax1.feedback()
    assert fb["vel"] == -10_000, "DECEL 10 deg/s^2, not ACCEL, brakes"
    clock.sleep(1.5)
    fb = ax1.feedback()
    assert fb["vel"] == 0 and not fb["status"] & MOVING
    assert fb["pos"] == pytest.approx(pos_at_stop - 20_000, abs=1), "v^2 / 2d = 20 deg"


def test_rate_mode_brakes_onto_the_soft_limit(ax0, clock):
    ax0.write(ENABLE, 1)
    ax0.write32(SOFT_LIMIT_POS, 30_000)
    ax0.profile(0, 20_000, 40_000)
    ax0.command(MOVE_VEL)
    clock.sleep(5.0)
    fb = ax0.feedback()
    assert fb["pos"] == 30_000 and fb["vel"] == 0 and fb["status"] & LIMIT_POS
    assert ax0.command(MOVE_VEL).exception_code == 3
    assert ax0.feedback()["last_error"] == 2
    ax0.profile(0, -20_000, 40_000)
    assert not ax0.command(MOVE_VEL).isError(), "away from the limit is allowed"


def test_home_sets_homing_then_homed_at_physical_zero(ax0, clock):
    ax0.write(ENABLE, 1)
    ax0.profile(45_000, 45_000, 90_000)
    ax0.command(MOVE_ABS)
    clock.sleep(2.0)
    ax0.command(SET_ZERO)
    fb = ax0.feedback()
    assert fb["pos"] == 0
    ax0.command(HOME)
    fb = ax0.feedback()
    assert fb["status"] & HOMING and not fb["status"] & HOMED
    clock.sleep(0.5)
    assert ax0.feedback()["status"] & HOMING
    clock.sleep(2.0)
    fb = ax0.feedback()
    assert fb["status"] & HOMED and not fb["status"] & HOMING
    assert fb["counts"] == 0 and fb["pos"] == 0


def test_disable_mid_move_decelerates_and_drops_in_position(ax0, clock):
    ax0.write(ENABLE, 1)
    ax0.profile(90_000, 30_000, 60_000)
    ax0.command(MOVE_ABS)
    clock.sleep(1.0)
    ax0.write(ENABLE, 0)
    clock.sleep(0.25)
    fb = ax0.feedback()
    assert fb["vel"] == 15_000 and not fb["status"] & ENABLED
    clock.sleep(2.0)
    fb = ax0.feedback()
    assert fb["vel"] == 0 and not fb["status"] & IN_POSITION
    assert ax0.command(MOVE_ABS).exception_code == 4


def test_little_endian_word_order_profile(clock):
    tt = FakeTurntable(clock, word_order="little", start_angles=(-1.5, 0.0))
    with TurntableServer(tt) as srv:
        c = connect(srv)
        rr = c.read_holding_registers(0x0110, count=2, device_id=1)
        c.close()
    assert c.convert_from_registers(rr.registers, c.DATATYPE.INT32, word_order="little") == -1500
    assert rr.registers == [(-1500) & 0xFFFF, 0xFFFF]
