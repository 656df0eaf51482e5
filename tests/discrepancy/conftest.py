"""Blind sessions for the discrepancy tests: draw, simulate, analyse; the analysis never sees the truth."""

import numpy as np

from fixtures.world.draw import draw_effect, research_environment, standard_plan
from fixtures.world.model import random_sensor_models
from fixtures.world.session_sim import simulate_session
from rig.discrepancy import analyze

DURATION_S = 170.0


def session_for(effects: list[tuple[str, str]], seed: int, **design):
    """Simulate a session with the named (effect, sensor) pairs drawn at realistic sizes."""
    rng = np.random.default_rng(1000 + seed)
    drawn = [draw_effect(name, rng, sensor=sensor, duration_s=DURATION_S, magnitude=design.get("magnitude"))
             for name, sensor in effects]
    env = research_environment() if design.get("research_env") else None
    if "temperature" in design:
        from fixtures.world.model import Environment
        env = Environment(temperature=design["temperature"])
    sensors = random_sensor_models(rng, **({"gyro_noise": design["gyro_noise"]} if "gyro_noise" in design else {}))
    plan = standard_plan(seed=seed, hold_s=design.get("hold_s", 5.0))
    session, truth = simulate_session(sensors, plan, effects=drawn, env=env, seed=seed)
    return session, drawn


def blind(session):
    session.meta = {k: v for k, v in session.meta.items() if k != "truth"}
    return analyze(session)


def identifiable_magnitude(effect) -> float:
    """The part of the truth a session can see (see the candidates' docstrings)."""
    return effect.identifiable_magnitude()
