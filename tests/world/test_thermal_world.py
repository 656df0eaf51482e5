"""The simulated world's heat: a unit's temperature curves, the truth at a die temperature, the hysteresis between up
and down sweeps, and the chip emulators' one-sample path through temperature effects."""

import numpy as np
import pytest

from fixtures.chamber import FakeChamber
from fixtures.motion import TableTrack
from fixtures.world import Environment, SensorModel, World, random_sensor_models
from fixtures.world.effects.thermal_hysteresis import ThermalHysteresis
from fixtures.world.heat import curves_at, unit_thermal_effects
from rig.clock import SimClock
from rig.units import DEG

G = 9.80665


def world_at(temperature, effects, seed=0, noise=True):
    models = random_sensor_models(np.random.default_rng(seed))
    if not noise:
        models = {k: SensorModel(m.kind, m.H, m.B, 0.0) for k, m in models.items()}
    return World(TableTrack(30.0, 45.0), models, env=Environment(temperature=temperature), effects=effects)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_units_curves_have_realistic_sizes_over_a_chamber_range(seed):
    effects = unit_thermal_effects(seed)
    world = world_at(lambda t: np.full(np.shape(t), 25.0), effects, seed, noise=False)
    for sensor, (lo, hi), unit in (("gyro", (0.35, 2.8), DEG), ("accel", (0.5e-3 * G, 4e-3 * G), 1.0)):
        m = world.sensors[sensor]
        B_cold = curves_at(effects, sensor, m.H, m.B, -10.0)[1]
        B_hot = curves_at(effects, sensor, m.H, m.B, 60.0)[1]
        moved = np.abs(B_hot - B_cold).max() / unit        # over 70 C: tens of mdps/C, a few mg
        assert lo < moved < hi, (sensor, moved)
        H_cold = curves_at(effects, sensor, m.H, m.B, -10.0)[0]
        H_hot = curves_at(effects, sensor, m.H, m.B, 60.0)[0]
        ppm = np.abs(np.diag(np.linalg.solve(H_cold, H_hot)) - 1.0).max() * 1e6
        assert 100.0 < ppm < 700.0, (sensor, ppm)
        mid = curves_at(effects, sensor, m.H, m.B, 25.0)[1]
        line = 0.5 * (B_cold + B_hot)                     # curved: the middle is off the chord
        assert np.abs(mid - line).max() > 0.02 * np.abs(B_hot - B_cold).max()


@pytest.mark.parametrize("temp_c", [-5.0, 25.0, 55.0])
def test_the_truth_at_a_temperature_is_what_the_world_senses_there(temp_c):
    effects = unit_thermal_effects(4)
    world = world_at(lambda t: np.full(np.shape(t), temp_c), effects, 4, noise=False)
    ctx = world.context(np.array([0.0]))
    for sensor in ("accel", "gyro", "mag"):
        m = world.sensors[sensor]
        H_T, B_T = curves_at(effects, sensor, m.H, m.B, temp_c)
        u = ctx.f[0] if sensor == "accel" else (ctx.omega[0] if sensor == "gyro"
                                                 else ctx.R[0].T @ world.env.field_world())
        sensed = world.sense(sensor, 0.0, noise=False)[0]
        np.testing.assert_allclose(H_T @ (sensed - B_T), u, atol=1e-9 * max(1.0, np.abs(u).max()))


def test_the_one_sample_path_through_temperature_effects_is_the_worlds_model():
    effects = unit_thermal_effects(6, hysteresis=False)
    fast = world_at(lambda t: 20.0 + 0.01 * np.asarray(t), effects, 6, noise=False)
    for t in (0.0, 100.0, 2000.0):
        for sensor in ("accel", "gyro", "mag"):
            np.testing.assert_allclose(fast.sense_floats(sensor, t), fast.sense(sensor, t, noise=False)[0],
                                       rtol=1e-12, atol=1e-12)


def test_hysteresis_separates_the_up_and_down_sweeps_by_twice_its_size_and_survives_a_soak():
    a = np.array([0.0, 0.02 * DEG, 0.0])
    hyst = ThermalHysteresis(sensor="gyro", a=a, width_c=3.0)
    profile = lambda t: np.interp(t, [0, 100, 200, 300, 400], [10.0, 40.0, 40.0, 10.0, 10.0])  # up, hold, down
    up = world_at(profile, [hyst], 1, noise=False)
    clean = world_at(profile, [], 1, noise=False)
    seen = {t: up.sense("gyro", t, noise=False)[0] - clean.sense("gyro", t, noise=False)[0]
            for t in np.arange(0.0, 401.0, 1.0)}
    rising, falling = seen[50.0], seen[250.0]          # both at 25 C
    np.testing.assert_allclose(rising - falling, 2 * a, atol=1e-12)
    np.testing.assert_allclose(seen[190.0], a, atol=1e-12)      # held at 40 C: not a lag, it stays
    np.testing.assert_allclose(seen[400.0], -a, atol=1e-12)
    assert hyst.magnitude() == pytest.approx(0.02)


def test_the_chamber_die_is_the_worlds_temperature_on_one_clock():
    clock = SimClock()
    chamber = FakeChamber(clock)
    world = world_at(chamber.die_at, unit_thermal_effects(1), 1)
    source = world.source("gyro")
    before = source.temperature_c(clock.now())
    chamber.state.set_point, chamber.state.running = 60.0, True
    clock.sleep(1800.0)
    assert source.temperature_c(clock.now()) == pytest.approx(chamber.die_c(), abs=1e-9)
    assert source.temperature_c(clock.now()) > before + 20.0
    assert world.env.temp_at(900.0) == pytest.approx(float(chamber.die_at(900.0)))     # the past is kept
    assert before < world.env.temp_at(900.0) < chamber.die_c()
