"""Simulated still logs of a board warming from a cold soak, the shape of PX4's and ArduPilot's thermal logs.

The board sits still (one table pose) while its die warms as T(t) = T0 + rise (1 - exp(-t / tau)), from a cold
soak of -5..10 C by 25..40 C over a time constant of 5..15 min (a powered board in a warm room). The chip's
thermometer reads the die with white noise and rounds to the MPU-6050's step (1/340 C). Each sensor axis's bias
moves with temperature as a polynomial in x = (T - 25 C) / SPAN_C ("flat": not at all, "linear", "cubic"), drawn
at realistic sizes (gyroscope tens of mdps/C, accelerometer tenths of a mg/C, as temperature_bias draws), on top
of the simulated world's white noise and a Gauss-Markov bias instability. Returns the session and the true
offset curve's coefficients (powers 1..3, sensor axes, in counts).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fixtures.world.effects_base import TO_PHYS, Effect
from fixtures.world.effects.noise import BiasInstability
from fixtures.world.model import Environment, random_sensor_models
from fixtures.world.session_sim import NOMINAL, SessionPlan, simulate_session
from rig.noise.thermal_warmup import fit_warmup_session, held_out

SPAN_C = 17.5
THERMOMETER_STEP_C = 1.0 / 340.0
THERMOMETER_NOISE_C = 0.03
SLOPE = {"gyro": (0.02, 0.06), "accel": (0.2, 0.6)}        # deg/s per C / mg per C, the linear term's size
CURVATURE = {"gyro": 0.3, "accel": 0.3}                     # x^2 and x^3 terms' sizes relative to the linear term
INSTABILITY = {"gyro": 0.003, "accel": 0.05}               # deg/s / mg, Gauss-Markov sigma
TO_REPORT = {"gyro": TO_PHYS["gyro"], "accel": 9.80665e-3}                # physical unit per deg/s / per mg


@dataclass
class TemperatureCurve(Effect):
    """Each sensor axis's bias += sum_j c[j-1] x^j, x = (T - 25) / SPAN_C; c (3 powers, 3 axes) physical units."""

    c: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    name: str = "temperature_bias"

    def output(self, ctx, s):
        x = (np.asarray(ctx.temp, dtype=float) - 25.0) / SPAN_C
        return s + np.stack([x, x ** 2, x ** 3], axis=-1) @ self.c

    def magnitude(self):
        return float(np.abs(self.c[0]).max() / SPAN_C / TO_PHYS[self.sensor])

    def params(self):
        return {"c": self.c / TO_PHYS[self.sensor], "span_c": SPAN_C}


def draw_curve(rng: np.random.Generator, sensor: str, shape: str) -> np.ndarray:
    """Coefficients (powers 1..3, axes) in physical units of a realistic curve of `shape`."""
    c = np.zeros((3, 3))
    if shape == "flat":
        return c
    slope = rng.uniform(*SLOPE[sensor], 3) * rng.choice([-1.0, 1.0], 3)          # per C
    c[0] = slope * SPAN_C
    if shape == "cubic":
        c[1] = CURVATURE[sensor] * np.abs(c[0]) * rng.choice([-1.0, 1.0], 3)
        c[2] = CURVATURE[sensor] * np.abs(c[0]) * rng.choice([-1.0, 1.0], 3)
    return c * TO_REPORT[sensor]


@dataclass
class WarmupLog:
    session: object
    sensor: str
    curve_counts: np.ndarray      # (3 powers, 3 axes): the true offset curve in counts, x = (T - 25) / SPAN_C
    die_c: np.ndarray             # the true die temperature of each row


def warmup_log(rng: np.random.Generator, sensor: str = "gyro", shape: str = "cubic", duration_s: float = 2400.0,
               rate_hz: float = 50.0) -> WarmupLog:
    """One simulated still warm-up log (module docstring)."""
    T0, rise, tau = rng.uniform(-5.0, 10.0), rng.uniform(25.0, 40.0), rng.uniform(300.0, 900.0)
    env = Environment(temperature=lambda t: T0 + rise * (1.0 - np.exp(-np.asarray(t, dtype=float) / tau)))
    models = random_sensor_models(rng)
    c = draw_curve(rng, sensor, shape)
    effects = [TemperatureCurve(sensor=sensor, c=c),
               BiasInstability(sensor=sensor, sigma=np.full(3, INSTABILITY[sensor] * TO_REPORT[sensor]),
                               tau_s=60.0, seed=int(rng.integers(1 << 30)))]
    plan = SessionPlan(schedule=[(0.0, 0.0)], hold_s=duration_s, rate_hz=rate_hz)
    session, _ = simulate_session({sensor: models[sensor]}, plan, effects=effects, env=env,
                                  seed=int(rng.integers(1 << 30)))
    die = np.asarray(session.temp_c, dtype=float).copy()
    read = die + rng.normal(0.0, THERMOMETER_NOISE_C, die.size)
    session.temp_c = np.round(read / THERMOMETER_STEP_C) * THERMOMETER_STEP_C
    counts = NOMINAL[sensor]["scale"]
    return WarmupLog(session=session, sensor=sensor, curve_counts=c * counts, die_c=die)


def true_offset(log: WarmupLog, temp_c) -> np.ndarray:
    """The true offset curve (counts, constant term zero) at temperatures `temp_c`: (n, 3)."""
    x = (np.atleast_1d(np.asarray(temp_c, dtype=float)) - 25.0) / SPAN_C
    return np.stack([x, x ** 2, x ** 3], axis=-1) @ log.curve_counts


def campaign(sensor: str, shape: str, seeds: int, seed: int) -> list[dict]:
    """Per simulated log: the held-out comparison (warmup.held_out), the fit on the whole log, and the truth."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(seeds):
        log = warmup_log(rng, sensor, shape)
        s = log.session
        held = held_out(sensor, s.temp_c, s.raw[sensor], rate_hz=s.sample_rate_hz)
        fit = fit_warmup_session(s, sensor)
        out.append({"log": log, "held": held, "fit": fit})
    return out
