"""The simulated world against the conventions: geometry, rates, clock, effects, direct sessions."""

import time

import numpy as np
import pytest

from fixtures.motion import TableTrack
from fixtures.world import EFFECTS, Environment, SensorModel, World, random_sensor_models
from fixtures.world.effects.earth_rotation import EarthRotation
from fixtures.world.effects.table_magnetic_disturbance import TableMagneticDisturbance
from fixtures.world.effects.time_offset import TimeOffset
from fixtures.world.session_sim import SessionPlan, simulate_session
from rig.clock import SimClock
from rig.rotations import matrix_from_rotvec, rot_x, rot_z


def ideal(kind):
    return SensorModel(kind, np.eye(3), np.zeros(3), 0.0)


def ideal_world(track, **kw):
    return World(track, {k: ideal(k) for k in ("accel", "gyro", "mag")}, **kw)


@pytest.mark.parametrize("outer,inner", [(0, 0), (90, 0), (30, 45), (-120, 170), (180, -90)])
def test_gravity_and_field_follow_the_tumble_geometry(outer, inner):
    w = ideal_world(TableTrack(outer, inner))
    R = rot_x(np.radians(outer)) @ rot_z(np.radians(inner))
    f = w.sense("accel", 0.0, noise=False)[0]
    m = w.sense("mag", 0.0, noise=False)[0]
    np.testing.assert_allclose(f, R.T @ [0, 0, 9.80665], atol=1e-12)
    np.testing.assert_allclose(m, R.T @ Environment().field_world(), atol=1e-12)
    assert np.linalg.norm(m) == pytest.approx(50.0)
    assert Environment().field_world()[2] < 0   # the field points down


def test_level_table_reads_plus_g_on_z():
    w = ideal_world(TableTrack(0, 0))
    np.testing.assert_allclose(w.sense("accel", 1.0, noise=False)[0], [0, 0, 9.80665])


def _integrate(t, omega):
    R = np.eye(3)
    for k in range(len(t) - 1):
        R = R @ matrix_from_rotvec(0.5 * (omega[k] + omega[k + 1]) * (t[k + 1] - t[k]))
    return R


def test_integrated_body_rates_reproduce_the_rotation_between_holds():
    track = TableTrack(10.0, -20.0)
    track.axes[0].move_to(0.0, 130.0, 60.0, 120.0)
    track.axes[1].move_to(0.3, 75.0, 45.0, 90.0)
    w = ideal_world(track)
    t = np.linspace(0.0, 6.0, 60001)
    omega = w.sense("gyro", t, noise=False)
    R0 = rot_x(np.radians(10)) @ rot_z(np.radians(-20))
    R1 = rot_x(np.radians(130)) @ rot_z(np.radians(75))
    np.testing.assert_allclose(_integrate(t, omega), R0.T @ R1, atol=1e-6)


def test_fast_scalar_path_matches_vectorised_model():
    track = TableTrack(0, 0)
    track.axes[0].move_to(0.0, 100.0, 50.0, 100.0)
    track.axes[1].move_to(0.0, -60.0, 50.0, 100.0)
    sensors = random_sensor_models(np.random.default_rng(2), accel_noise=0, gyro_noise=0, mag_noise=0)
    w = World(track, sensors)
    for name in sensors:
        for t in (0.1, 0.77, 1.5, 2.5):
            np.testing.assert_allclose(w.sense_one(name, t), w.sense(name, t)[0], atol=1e-12)


def test_sim_clock_makes_a_100s_move_without_waiting_on_the_wall(monkeypatch):
    """A SimClock without a time scale advances itself: a 100 s move sensed every 10 ms never sleeps for real."""
    clock = SimClock()
    track = TableTrack()
    arrival = track.axes[0].move_to(clock.now(), 3000.0, 30.0, 10.0)
    assert arrival > 100.0
    w = ideal_world(track)
    src = w.source("gyro")
    slept: list[float] = []
    monkeypatch.setattr(time, "sleep", slept.append)
    while clock.now() < arrival:
        clock.sleep(0.01)
        src.sense(clock.now())
    assert slept == []
    assert track.axes[0].state(clock.now())[0] == pytest.approx(3000.0)


def test_effects_are_off_by_default_and_pluggable():
    base = ideal_world(TableTrack(45, 30))
    assert base.effects == []
    omega = np.radians(15.0 / 3600.0) * np.array([0.0, 0.7, 0.7])
    w = ideal_world(TableTrack(45, 30), effects=[EarthRotation("gyro", Omega=omega)])
    R = rot_x(np.radians(45)) @ rot_z(np.radians(30))
    np.testing.assert_allclose(w.sense("gyro", 0.0, noise=False)[0], R.T @ omega, atol=1e-15)
    d = np.array([3.0, -2.0, 1.0])
    base = ideal_world(TableTrack(0, 90))
    w = ideal_world(TableTrack(0, 90), effects=[TableMagneticDisturbance("mag", d=d)])
    extra = w.sense("mag", 0.0, noise=False)[0] - base.sense("mag", 0.0, noise=False)[0]
    np.testing.assert_allclose(extra, rot_z(np.radians(-90)) @ d, atol=1e-12)
    assert set(EFFECTS) >= {"gyro_g_sensitivity", "earth_rotation", "time_offset", "mag_offset_flip"}


def test_time_offset_delays_what_the_gyro_senses():
    track = TableTrack()
    track.axes[0].run_at(0.0, 50.0, 100.0)   # ramps for 0.5 s
    plain = ideal_world(track)
    lagged = ideal_world(track, effects=[TimeOffset("gyro", tau=0.02)])
    np.testing.assert_allclose(lagged.sense("gyro", 0.3, noise=False), plain.sense("gyro", 0.28, noise=False))


def test_direct_session_matches_its_truth():
    rng = np.random.default_rng(5)
    plan = SessionPlan([(0, 0), (90, 0), (90, 90), (45, 135), (135, -45), (180, 30)], hold_s=2.0)
    session, truth = simulate_session(random_sensor_models(rng), plan, seed=5)
    holds = session.holds("accel")
    H, B = np.array(truth["sensors"]["accel"]["H"]), np.array(truth["sensors"]["accel"]["B"])
    u = (holds.mean - B) @ H.T
    expected = np.einsum("kji,j->ki", holds.R, [0, 0, 9.80665])
    assert np.abs(u - expected).max() < 0.02      # noise and quantisation of 200-sample means
    assert len(session.moves("gyro")) == len(plan.schedule) - 1
    assert np.isnan(session.raw["mag"][1::2]).all() and not np.isnan(session.raw["mag"][::2]).any()
