"""Ours, a model told the true curves' orders (what noise alone leaves), and the peers, on the same steps; for the
accelerometer also the joint fit to the same hold means."""

from __future__ import annotations

import numpy as np

from rig.calibration.thermal import fit_thermal_model
from rig.calibration.thermal.joint import fit_thermal_model_joint
from rig.calibration.thermal.peers import ardupilot_offset_fit, px4_offset_fit

from thermal_synth import G, accel_holds, errors, held_out_temps, make_unit, steps_from_holds, thermal_steps



def compare_unit(sensor: str, rng: np.random.Generator, shape: str = "cubic", with_joint: bool = False
                 ) -> dict[str, np.ndarray]:
    """For one simulated unit: per method, an array (held-out temperatures, 3) of bias, scale (ppm) and output
    error (thermal_synth.errors)."""
    unit = make_unit(sensor, rng, shape)
    holds = accel_holds(unit, rng) if sensor == "accel" else None
    steps = steps_from_holds(holds) if holds else thermal_steps(unit, rng)
    ours = fit_thermal_model(sensor, steps)
    oracle = fit_thermal_model(sensor, steps, orders=unit.true_orders())
    T = np.array([s.temp_c for s in steps])
    offsets = np.stack([s.calibration.B for s in steps])
    cal = steps[int(np.argmin(np.abs(T - ours.reference_c)))]          # the one calibration the peers keep
    peers = {f.__name__.split("_")[0]: f(T, offsets, cal.calibration.B, cal.calibration.H, cal.temp_c)
             for f in (px4_offset_fit, ardupilot_offset_fit)}
    out = {}
    joint = [("joint", fit_thermal_model_joint(sensor, holds, G))] if holds and with_joint else []
    for name, model in (("ours", ours), ("true_orders", oracle), *peers.items(), *joint):
        rows = []
        for t in held_out_temps():
            e = errors(unit, model.B_at(t), model.H_at(t), t)
            rows.append([e["bias"], e["scale_ppm"], e["output"]])
        out[name] = np.array(rows)
    return out


def campaign(sensor: str, seeds: int, seed: int, shape: str = "cubic", with_joint: bool = False
             ) -> dict[str, np.ndarray]:
    """compare_unit over `seeds` units: per method (units, held-out temperatures, 3)."""
    rng = np.random.default_rng(seed)
    runs = [compare_unit(sensor, rng, shape, with_joint) for _ in range(seeds)]
    return {m: np.stack([r[m] for r in runs]) for m in runs[0]}


def rms(a: np.ndarray, axis) -> np.ndarray:
    return np.sqrt(np.mean(a ** 2, axis=axis))
