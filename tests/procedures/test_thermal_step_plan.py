"""The planner chooses a thermal step's schedule from `[thermal] step_H_std_pct` when `[thermal] orientations` is
not given: the chosen schedule's predicted H error meets the target, and a tighter target takes longer."""

from dataclasses import replace

from procedures.thermal_session import step_config, step_plan
from rig.commands.thermal_run import builtin_thermal_config
from rig.planner import NoiseModel, predict


def planned(target_pct: float):
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, orientations=0, hold_s=0.0, step_H_std_pct=target_pct)
    return config, step_plan(config)


def test_the_planned_step_schedule_meets_its_target_and_a_tighter_one_takes_longer():
    config, loose = planned(0.1)
    stepped = step_config(config)
    assert stepped.schedule.orientations == loose.orientations and stepped.schedule.hold_s == loose.hold_s
    again = predict(config, loose.schedule, loose.hold_s, NoiseModel())      # predicted anew, not the plan's figure
    assert max(p["H_rel_pct"] for p in again.values()) <= 0.1 * (1 + 1e-6)
    _, tight = planned(0.025)
    assert tight.eta_s > loose.eta_s
    assert max(p["H_rel_pct"] for p in tight.predicted.values()) <= 0.025 * (1 + 1e-6)


def test_stated_orientations_are_kept_without_the_planner():
    config = builtin_thermal_config()
    config.thermal = replace(config.thermal, step_H_std_pct=0.05)       # orientations = 9 in thermal.toml
    assert step_plan(config) is None
    assert step_config(config).schedule.orientations == config.thermal.orientations
