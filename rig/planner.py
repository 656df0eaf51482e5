"""Plan a session for a time budget or an accuracy target, from the Cramer-Rao bound.

A plan is the number of orientations (the lattice of `rig.schedule`: directions spread over the sphere, every
second one in the table's other pose, a short tour), the hold length and the move profile. The moves run at the
table's speed and acceleration limits of the configuration: a move's integrated rate noise grows with its
duration while its rotation does not, so the bound of the gyro's H only improves with faster moves, and the
holds get the time saved. For every candidate the predicted standard deviations of H (relative, Frobenius) and
B of the three sensors come from `rig.planner_bounds`; the objective weighs each against the configuration's own
plan ("today's default"), so that no sensor is traded away for another: sum over sensors of
(H / H_default)^2 + (B / B_default)^2. A budget picks the candidate of least objective that fits; a target the
shortest whose every sensor's predicted H error is within it. Only schedules that pass the observability check
are candidates, and holds stay long enough for bump detection and the settle rule (MIN_HOLD_S).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from rig.calibration.turntable.observability import check_schedule, move_axes_problem
from rig.config import RigConfig
from rig.errors import CalibrationError, InputError
from rig.planner_bounds import MOVE_DECIMATION, gyro_bound, move_rotations, vector_bound
from rig.schedule import Orientation, estimate_duration, plan_orientations, schedule_rotations
from rig.trapezoid import trapezoid

MIN_HOLD_S = 1.5          # bump detection judges 0.5 s windows and needs three of them (hold_has_motion)
MAX_HOLD_S = 60.0
ORIENTATIONS = range(9, 41)
SENSORS = ("accel", "gyro", "mag")
UNITS = {"accel": "m/s^2", "gyro": "rad/s", "mag": "uT"}
# White noise per sample (calibrated units) of the built-in simulated units, measured from their hold spreads
# (`rig plan --noise-from SESSION` takes a unit's own from a session it recorded).
SIMULATED_NOISE = {"accel": 0.0136, "gyro": 0.0041, "mag": 0.152}
FIELD_DIP_DEG, FIELD_DECLINATION_DEG = 60.0, 10.0     # the field's direction where a session has not measured it


@dataclass(frozen=True)
class NoiseModel:
    """White noise per sample of each sensor in its calibrated units (what the bound needs), and where it came from."""

    sigma: dict[str, float] = field(default_factory=lambda: dict(SIMULATED_NOISE))
    source: str = "the built-in simulated units' noise"


@dataclass
class Plan:
    orientations: int
    hold_s: float
    speed_dps: float
    accel_dps2: float
    eta_s: float
    schedule: list[Orientation]
    predicted: dict[str, dict[str, float]]      # sensor -> {"H_rel_pct", "B_sd", "unit"}
    objective: float = float("nan")

    def to_dict(self) -> dict:
        return {"orientations": self.orientations, "hold_s": self.hold_s, "speed_dps": self.speed_dps,
                "accel_dps2": self.accel_dps2, "eta_s": round(self.eta_s, 2), "objective": round(self.objective, 4),
                "predicted": self.predicted}


def field_world(field_uT: float) -> np.ndarray:
    d, i = math.radians(FIELD_DECLINATION_DEG), math.radians(FIELD_DIP_DEG)
    return field_uT * np.array([math.cos(i) * math.sin(d), math.cos(i) * math.cos(d), -math.sin(i)])


def move_seconds(schedule: list[Orientation], speed_dps: float, accel_dps2: float) -> np.ndarray:
    """Seconds of motion of each move (the slower axis's trapezoid)."""
    return np.array([trapezoid(max(abs(q.outer_deg - p.outer_deg), abs(q.inner_deg - p.inner_deg)), speed_dps,
                               accel_dps2).duration for p, q in zip(schedule[:-1], schedule[1:])])


def observable(config: RigConfig, schedule: list[Orientation]) -> bool:
    R = schedule_rotations(schedule, config.geometry)
    return check_schedule(R).ok and move_axes_problem(np.einsum("kji,kjl->kil", R[:-1], R[1:])) is None


def predict(config: RigConfig, schedule: list[Orientation], hold_s: float, noise: NoiseModel,
            move_samples: bool = True) -> dict:
    """Predicted standard deviations of every sensor's H (relative RMS, %) and B (RMS, units) for the plan;
    with `move_samples` the accelerometer and magnetometer use their samples of the moves too, as the
    pipeline does by default."""
    t, s = config.turntable, config.schedule
    R = schedule_rotations(schedule, config.geometry)
    n = len(schedule)
    samples = np.full(n, max(int(hold_s * s.rate_hz), 1))
    moving = move_path(config, schedule) if move_samples else None
    out = {}
    for name in SENSORS:
        sigma = noise.sigma[name]
        if name == "gyro":
            H, B = gyro_bound(R, move_seconds(schedule, t.speed_dps, t.accel_dps2), sigma, s.rate_hz, samples)
        else:
            ref = np.array([0.0, 0.0, config.gravity_mps2]) if name == "accel" else field_world(config.field_uT)
            every = 1 if name == "accel" else max(s.mag_every, 1)
            H, B = vector_bound(R, ref, sigma, np.maximum(samples // every, 1),
                                None if moving is None else moving[::every * MOVE_DECIMATION], MOVE_DECIMATION)
        out[name] = {"H_rel_pct": 100 * H, "B_sd": B, "unit": UNITS[name]}
    return out


def move_path(config: RigConfig, schedule: list[Orientation]) -> np.ndarray:
    """Orientations (m, 3, 3) of the fixture at every sample tick of the schedule's moves: the motion at the
    table's limits, then the settle time and the two status polls (see `eta`) before the next hold begins."""
    t, s = config.turntable, config.schedule
    return move_rotations(np.array([o.outer_deg for o in schedule]), np.array([o.inner_deg for o in schedule]),
                          config.geometry, t.speed_dps, t.accel_dps2, s.rate_hz,
                          t.settle_s + 2 * t.poll_every / s.rate_hz)


def eta(config: RigConfig, schedule: list[Orientation], hold_s: float) -> float:
    """Seconds of table time: the schedule's holds and trapezoidal moves, plus two status polls a move (its arrival
    is seen at a poll and its settle time counted from one: 0.19 s a move measured on the simulated rig)."""
    t = config.turntable
    polls = 2 * t.poll_every / config.schedule.rate_hz * max(len(schedule) - 1, 0)
    return polls + estimate_duration(schedule, hold_s=hold_s, speed_dps=t.speed_dps, accel_dps2=t.accel_dps2,
                                     settle_s=t.settle_s)


def default_plan(config: RigConfig, noise: NoiseModel) -> Plan:
    """The configuration's own plan (today's default session), predicted (nothing predicted where the schedule
    cannot determine every parameter: the observability check names why)."""
    schedule = plan_orientations(config.schedule.orientations)
    hold = config.schedule.hold_s
    try:
        predicted = predict(config, schedule, hold, noise)
    except CalibrationError:
        predicted = {}
    return _plan(config, schedule, hold, predicted)


def _reference(config: RigConfig, noise: NoiseModel) -> dict:
    ref = default_plan(config, noise).predicted
    if not ref:
        raise InputError(f"{config.source}: the configuration's own schedule does not determine every sensor's B and "
                         "H (see `rig plan`), so there is no plan to weigh against")
    return ref


def _plan(config: RigConfig, schedule, hold_s: float, predicted: dict, objective: float = float("nan")) -> Plan:
    t = config.turntable
    return Plan(len(schedule), round(hold_s, 2), t.speed_dps, t.accel_dps2, eta(config, schedule, hold_s),
                schedule, predicted, objective)


def objective(predicted: dict, reference: dict) -> float:
    return float(sum((predicted[s]["H_rel_pct"] / reference[s]["H_rel_pct"]) ** 2
                     + (predicted[s]["B_sd"] / reference[s]["B_sd"]) ** 2 for s in SENSORS))


def _candidates(config: RigConfig):
    for n in ORIENTATIONS:
        try:
            schedule = plan_orientations(n)
        except ValueError:
            continue
        if observable(config, schedule):
            yield schedule, eta(config, schedule, 0.0)


def plan_for_budget(config: RigConfig, budget_s: float, noise: NoiseModel | None = None) -> Plan:
    """The plan of least objective whose ETA fits `budget_s` seconds of table time."""
    noise = noise or NoiseModel()
    ref = _reference(config, noise)
    best = None
    for schedule, moving in _candidates(config):
        hold = min(math.floor((budget_s - moving) / len(schedule) * 100) / 100, MAX_HOLD_S)
        if hold < MIN_HOLD_S:
            continue
        try:
            predicted = predict(config, schedule, hold, noise)
        except CalibrationError:
            continue
        cost = objective(predicted, ref)
        if best is None or cost < best.objective:
            best = _plan(config, schedule, hold, predicted, cost)
    if best is None:
        shortest = min((moving + MIN_HOLD_S * len(s) for s, moving in _candidates(config)), default=float("nan"))
        raise InputError(f"--budget-s {budget_s:g}: no observable plan fits; the shortest takes {shortest:.0f} s "
                         f"(9 orientations of {MIN_HOLD_S:g} s holds at {config.turntable.speed_dps:g} deg/s)")
    return best


def plan_for_target(config: RigConfig, target_h_pct: float, noise: NoiseModel | None = None) -> Plan:
    """The shortest plan whose every sensor's predicted H error (relative RMS, %) is at most `target_h_pct`."""
    noise = noise or NoiseModel()
    ref = _reference(config, noise)
    best, floor = None, math.inf
    for schedule, _ in _candidates(config):
        try:
            at_one = predict(config, schedule, 1.0, noise)
        except CalibrationError:
            continue
        # accelerometer and magnetometer: H error ~ 1/sqrt(hold samples); the gyro's H comes from the moves
        need = max((at_one[s]["H_rel_pct"] / target_h_pct) ** 2 for s in ("accel", "mag"))
        hold = min(max(math.ceil(need * 100) / 100, MIN_HOLD_S), MAX_HOLD_S)
        predicted = predict(config, schedule, hold, noise)
        worst = max(p["H_rel_pct"] for p in predicted.values())
        floor = min(floor, worst)
        if worst > target_h_pct * (1 + 1e-9):
            continue
        plan = _plan(config, schedule, hold, predicted, objective(predicted, ref))
        if best is None or plan.eta_s < best.eta_s:
            best = plan
    if best is None:
        raise InputError(f"--target-h-pct {target_h_pct:g}: no plan of {ORIENTATIONS.start}-{ORIENTATIONS.stop - 1} "
                         f"orientations with holds up to {MAX_HOLD_S:g} s reaches it; the best predicted is "
                         f"{floor:.4g} %")
    return best


def applied(config: RigConfig, plan: Plan) -> RigConfig:
    """A copy of `config` whose schedule is the plan (what the orchestrator records and `rig resume` reads back)."""
    out = copy.deepcopy(config)
    out.schedule.orientations = plan.orientations
    out.schedule.hold_s = plan.hold_s
    out.turntable.speed_dps = plan.speed_dps
    out.turntable.accel_dps2 = plan.accel_dps2
    return out


def units_per_hour(table_s: float, mount_s: float, slots: int = 1) -> float:
    """Units calibrated per hour: `slots` units per session, a session being its table time and the mounting
    between sessions ([schedule] mount_s)."""
    return slots * 3600.0 / (table_s + mount_s)
