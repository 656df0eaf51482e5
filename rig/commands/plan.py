"""`rig plan`: the schedule of a session, its observability, its predicted accuracy and its ETA; nothing moves.

With `--budget-s S` or `--target-h-pct P` the planner (`rig.planner`) chooses the orientations, hold length and
move profile; `rig calibrate --sim --budget-s S` runs what it chose. The noise the bound needs is the built-in
simulated units' unless `--noise-from SESSION` names a session of the unit (its hold spreads, calibrated).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import click

from rig.board import i2c_clock_hz
from rig.commands.common import rig_config
from rig.exits import CommandError, Exit, FiniteFloat, plain

if TYPE_CHECKING:
    from rig.bus_budget import BusLoad

BUDGET_HELP = "Plan for this many seconds of table time (the most accurate plan that fits)."
TARGET_HELP = "Plan for this H error (relative RMS, %, every sensor): the shortest plan predicted to reach it."
SLOTS = 1               # units on the table in one session
NOISE_HELP = "Take the noise from a session of this unit (its folder, with calibration.json) instead of the default."


def planned_config(config, budget_s: float | None, target_h_pct: float | None, noise_from: str | None):
    """(the configuration with the planner's choice applied, the plan, the default plan), or the configuration's
    own plan when neither a budget nor a target is given."""
    from rig import planner
    from rig.errors import InputError

    noise = noise_of_session(Path(noise_from)) if noise_from else planner.NoiseModel()
    try:
        default = planner.default_plan(config, noise)
        if budget_s is None and target_h_pct is None:
            return config, default, default, noise
        plan = (planner.plan_for_budget(config, budget_s, noise) if budget_s is not None
                else planner.plan_for_target(config, target_h_pct, noise))
    except InputError as exc:
        raise CommandError(plain(str(exc)), Exit.BAD_INPUT) from None
    except ValueError as exc:          # the configuration's own schedule cannot be laid out
        raise CommandError(f"{config.source}: {plain(str(exc))}", Exit.BAD_INPUT) from None
    return planner.applied(config, plan), plan, default, noise


def refuse_orientations_with_planner(orientations, budget_s, target_h_pct) -> None:
    """--orientations with a budget or a target contradicts them: the planner chooses the number of orientations,
    and `--orientations 12 --budget-s 60` silently ran 19."""
    if orientations and (budget_s is not None or target_h_pct is not None):
        raise click.UsageError("--orientations and --budget-s/--target-h-pct contradict each other: with a budget "
                               "or a target the planner chooses the orientations; give one or the other")


def noise_of_session(folder: Path):
    """The white noise per sample of each sensor of a recorded session, in calibrated units: the median over its
    holds of each axis's spread, through the session's own calibration (`calibration.json` beside it)."""
    import numpy as np

    from rig import planner
    from rig.commands.common import read_any_session
    from rig.errors import RigError

    cal_path = folder / "calibration.json"
    try:
        cal = json.loads(cal_path.read_text())
        session = read_any_session(folder)
    except FileNotFoundError as exc:
        raise CommandError(f"--noise-from {folder}: {exc.filename} not found (a calibrated session folder is needed)",
                           Exit.BAD_INPUT) from None
    except (OSError, ValueError, RigError) as exc:
        raise CommandError(f"--noise-from {folder}: {plain(str(exc))}", Exit.BAD_INPUT) from None
    sigma = dict(planner.SIMULATED_NOISE)
    for name in planner.SENSORS:
        try:
            H = np.asarray(cal["sensors"][name]["H"], dtype=float).reshape(3, 3)
            std = np.median(session.holds(name).std, axis=0)
        except (KeyError, TypeError, ValueError) as exc:
            raise CommandError(f"--noise-from {cal_path}: sensors.{name}: {exc}", Exit.BAD_INPUT) from None
        value = float(np.sqrt(np.mean((H**2) @ std**2)))
        if not np.isfinite(value) or value <= 0:
            raise CommandError(f"--noise-from {folder}: {name}: no hold spread to take the noise from", Exit.BAD_INPUT)
        sigma[name] = value
    return planner.NoiseModel(sigma, f"measured in {folder}")


class StillWorld:
    """The unit at rest, upright: all a bus budget needs from the world is that every chip has something to sample."""

    READINGS = {"accel": (0.0, 0.0, 9.80665), "gyro": (0.0, 0.0, 0.0), "mag": (20.0, 0.0, -40.0)}

    def source(self, kind: str):
        import numpy as np

        from fixtures.sources import ConstantSource

        return ConstantSource(np.array(self.READINGS[kind]))


@dataclass(frozen=True)
class BusBudget:
    """The bus loads of a configuration's boards and the rate a session of it ticks at, which they are budgeted at:
    `procedures.acquisition.grid_rate_hz` of the boards for the schedule's `requested_hz`, from the output rate the
    gyro chips declare (`chip_hz`, None when they are read on demand). The chips are emulated with their nominal
    oscillator, so a part's trim (read when the real hardware starts) is not in it."""

    loads: list[BusLoad]
    rate_hz: float
    requested_hz: float
    chip_hz: float | None

    def why(self) -> str | None:
        """Why the budgeted rate is not the configured one, or None when it is."""
        if self.rate_hz == self.requested_hz or self.chip_hz is None:
            return None
        divisor = round(self.chip_hz / self.rate_hz)
        share = "" if divisor == 1 else f" / {divisor}"
        return (f"the session ticks at the gyro chips' output rate, {self.chip_hz:g} Hz{share}, the nearest it can "
                f"to the configured {self.requested_hz:g} Hz")


def simulated_bus_budget(config) -> BusBudget:
    """The bus loads of the configuration's board, measured with its own drivers on emulated chips (the transfers
    are the drivers', so they are the real board's too), at the rate the session's grid will tick at; for a
    configuration of slots, every slot's reads in slot order on the one grid (`rig.bus_budget.tick_loads`), a slot
    behind a switch channel paying a select where the channel changes."""
    from fixtures.simrig import SimulatedBoard
    from procedures.acquisition import grid_rate_hz, output_rate_hz
    from procedures.slots import SlotsBoard
    from rig.board import build_board
    from rig.bus_budget import TrafficLog, board_reads, bus_names, counting_wiring, tick_loads
    from rig.clock import SimClock

    clock = SimClock()
    units = ([(slot.name, config.slot_configs()[slot.name], slot.mux) for slot in config.slots] if config.slots
             else [(None, config, None)])
    started = []
    for name, cfg, mux in units:
        log = TrafficLog()
        i2c_name, spi_name = bus_names(cfg.chips)
        board = build_board(cfg.board, counting_wiring(SimulatedBoard(cfg, clock, StillWorld()).wiring(), log,
                                                       i2c_name, spi_name), chips=cfg.chips)
        board.start()
        started.append((name, board, log, i2c_name, mux))
    grid = SlotsBoard({name: board for name, board, *_ in started}) if config.slots else started[0][1]
    requested = config.schedule.rate_hz
    rate = grid_rate_hz(grid, requested)
    reads = []
    for _, board, log, i2c_name, mux in started:
        for read in board_reads(board, log, mag_every=config.schedule.mag_every,
                                settle=lambda: clock.sleep(1.0 / rate)):
            on_i2c = any(bus == i2c_name for bus, _ in read.transfers)
            reads.append((i2c_name, read, mux[1] if mux is not None and on_i2c else None))
    return BusBudget(tick_loads(reads, i2c_clock=i2c_clock_hz(config.chips)), rate, float(requested),
                     output_rate_hz(grid, "gyro"))


def simulated_bus_loads(config) -> list[BusLoad]:
    """The loads of `simulated_bus_budget`."""
    return simulated_bus_budget(config).loads


def bus_budget(config) -> BusBudget:
    """`simulated_bus_budget`, refused (exit 2) when a bus cannot carry the rate the session will tick at."""
    from rig.bus_budget import refusal

    try:
        budget = simulated_bus_budget(config)
    except ValueError as e:          # a chip setting the drivers refuse ([chips.gyro] rate_hz = -50)
        raise CommandError(f"{config.source}: {e}", Exit.BAD_INPUT) from None
    why = refusal(budget.loads, budget.rate_hz)
    if why is not None:
        ticks = f" ({budget.why()})" if budget.why() else ""
        raise CommandError(f"{config.source}: [schedule] rate_hz = {config.schedule.rate_hz:g}{ticks}: {why}",
                           Exit.BAD_INPUT)
    return budget


def load_doc(load) -> dict:
    """A bus's load for the --json document (no Infinity: JSON has none)."""
    top = load.max_rate_hz()
    return {"bus": load.bus, "worst_tick_s": load.worst_tick_s, "mean_tick_s": load.seconds_per_tick,
            "transfers": load.transfers, "bytes": load.bytes, "max_rate_hz": top if math.isfinite(top) else None}


def predicted_lines(plan, default=None) -> list[str]:
    out = []
    for name, p in plan.predicted.items():
        line = f"  {name}: H {p['H_rel_pct']:.4f} % (relative RMS), B {p['B_sd']:.3g} {p['unit']}"
        if default is not None and default is not plan:
            d = default.predicted[name]
            line += f"   (default plan: H {d['H_rel_pct']:.4f} %, B {d['B_sd']:.3g} {d['unit']})"
        out.append(line)
    return out


@click.command()
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False))
@click.option("--orientations", type=click.IntRange(9, 64), default=None)
@click.option("--budget-s", type=FiniteFloat(1.0, 36000.0), default=None, help=BUDGET_HELP)
@click.option("--target-h-pct", type=FiniteFloat(0.0, 100.0, low_open=True), default=None, help=TARGET_HELP)
@click.option("--noise-from", type=click.Path(exists=True, file_okay=False), default=None, help=NOISE_HELP)
@click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Also write the plan and its prediction as JSON.")
def plan(config_path, orientations, budget_s, target_h_pct, noise_from, json_out):
    """Dry run: the schedule, its observability, its predicted accuracy and the ETA. Nothing moves."""
    import time

    from procedures.session import check_plan, plan_for
    from rig.planner import units_per_hour

    if budget_s is not None and target_h_pct is not None:
        raise click.UsageError("give --budget-s or --target-h-pct, not both")
    refuse_orientations_with_planner(orientations, budget_s, target_h_pct)
    started = time.perf_counter()
    config, chosen, default, noise = planned_config(rig_config(config_path, orientations), budget_s, target_h_pct,
                                                    noise_from)
    planning_s = time.perf_counter() - started
    budget = bus_budget(config)
    schedule = plan_for(config)
    t, s = config.turntable, config.schedule
    click.echo(f"{len(schedule)} orientations on a {config.board} board, holds of {s.hold_s} s at {s.rate_hz} Hz, "
               f"moves at up to {t.speed_dps:g} deg/s and {t.accel_dps2:g} deg/s^2")
    click.echo("  #   outer_deg   inner_deg")
    for k, o in enumerate(schedule):
        click.echo(f"{k:3d} {o.outer_deg:11.3f} {o.inner_deg:11.3f}")
    problems = check_plan(config, schedule)
    click.echo("observability: " + ("every axis excited" if not problems else "; ".join(problems)))
    if chosen.predicted:
        click.echo(f"predicted standard deviations (Cramer-Rao bound; noise: {noise.source}):")
        for line in predicted_lines(chosen, default):
            click.echo(line)
    click.echo(f"estimated rig time: {chosen.eta_s:.0f} s ({chosen.eta_s / 60:.1f} min)"
               + (f"; planned in {planning_s:.2f} s" if chosen is not default else ""))
    rate = budget.rate_hz
    click.echo(f"bus load at {rate:g} Hz (busiest tick, as % of the {1e3 / rate:.3g} ms tick; mean; "
               f"I2C at {i2c_clock_hz(config.chips) // 1000} kHz):")
    if budget.why():
        click.echo(f"  ({budget.why()})")
    for load in budget.loads:
        click.echo(f"  {load.bus}: {load.worst_tick_s * 1e3:.3g} ms = {load.load(rate) * 100:.1f} % "
                   f"(mean {load.seconds_per_tick * rate * 100:.1f} %), carries up to "
                   f"{load.max_rate_hz():g} Hz")
    slots = max(len(config.slots), SLOTS)
    per_hour = units_per_hour(chosen.eta_s, s.mount_s, slots)
    click.echo(f"units per hour: {per_hour:.2f} ({slots} slot{'s' if slots > 1 else ''} x 3600 s / "
               f"({chosen.eta_s:.0f} s on the table + {s.mount_s:g} s mounting))")
    if json_out is not None:
        doc = {"plan": chosen.to_dict(), "default": default.to_dict(), "noise": noise.sigma,
               "noise_source": noise.source, "planning_s": round(planning_s, 3), "observability": problems,
               "bus_load": [load_doc(x) for x in budget.loads], "bus_rate_hz": budget.rate_hz,
               "units_per_hour": per_hour}
        try:
            json_out.write_text(json.dumps(doc, indent=2) + "\n")
        except OSError as exc:
            raise CommandError(f"{json_out}: cannot write: {exc.strerror}", Exit.BAD_INPUT) from None
    if problems:
        sys.exit(Exit.FAIL)
