"""A thermal session from the command line (`rig calibrate --thermal`, `rig resume` of a thermal folder): its
hardware, real or simulated, the stop signals, the lines it prints and its exit code.

The simulated thermal rig is the simulated rig of `rig.assembly.build_sim` on one virtual clock with a fake
chamber (`fixtures.chamber`) served over Modbus TCP on loopback: the unit's die is the chamber's die, so the chips'
thermometers read it, and the unit carries the temperature curves its seed draws (`fixtures.world.heat`); with
`[thermal] sim_lag_s` its sensing elements follow the die through a lag (`fixtures.world.heat.LaggedElement`),
the temperature those curves see, while the thermometers read the die itself.
"""

from __future__ import annotations

import contextlib
import signal
from importlib import resources
from pathlib import Path

import click

from fixtures.chamber import ChamberServer, FakeChamber
from fixtures.world.heat import LaggedElement, truth_at, unit_thermal_effects
from procedures.orchestrator import RigSpec
from procedures.thermal_session import MANIFEST, ThermalOutcome, ThermalSession
from rig import assembly
from rig.chamber.client import ChamberLink
from rig.clock import RealClock, SimClock
from rig.commands.common import _Progress, _is_known, _signal_name, late_stop_signals
from rig.config import RigConfig, load_config
from rig.exits import CommandError, Exit, aborted, code_for, command_error, plain, stop_signals_raise
from rig.locks import chamber_lock


def builtin_thermal_config() -> RigConfig:
    """The built-in simulated thermal session's configuration (rig/configs/thermal.toml)."""
    with resources.as_file(resources.files("rig.configs").joinpath("thermal.toml")) as path:
        return load_config(path)


def is_thermal_session(folder: Path) -> bool:
    return (Path(folder) / MANIFEST).is_file()


class SimulatedThermalRig:
    """The simulated rig of every step and soak, and a fake chamber, on one clock (module docstring)."""

    def __init__(self, config: RigConfig, spec: RigSpec) -> None:
        self.config, self.spec = config, spec
        self.clock = SimClock(time_scale=spec.time_scale)
        self.fake = FakeChamber(self.clock, profile=config.chamber.profile)
        self.server = ChamberServer(self.fake)
        self.effects = unit_thermal_effects(spec.seed or 0, hysteresis=config.thermal.sim_hysteresis)
        lag = config.thermal.sim_lag_s
        self.element = LaggedElement(self.fake.die_at, lag, self.clock.now()) if lag else None
        self.rigs_built = 0

    def __enter__(self) -> "SimulatedThermalRig":
        self.server.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self.server.__exit__(*exc)

    def build_rig(self, config: RigConfig, spec) -> assembly.Rig:
        """A soak's or a step's rig: the same unit, its own noise (each step is measured apart from the others, so
        no two steps' calibrations share an error)."""
        self.rigs_built += 1
        rig = assembly.build_sim(config, seed=spec.seed or 0, trial=spec.trial, run=getattr(spec, "run", 0),
                                 clock=self.clock, temperature=self.fake.die_at, effects=self.effects,
                                 noise_stream=self.rigs_built)
        if self.element is not None:
            rig.world.env.element_temperature = self.element
        base = rig.truth_fn
        physical = {n: {"H": m.H, "B": m.B} for n, m in rig.world.sensors.items()}
        lag = {"element_lag_s": self.config.thermal.sim_lag_s} if self.element is not None else {}
        rig.truth_fn = lambda: {**truth_at(base(), physical, self.effects, self.fake.die_c()), **lag}
        return rig

    def chamber(self) -> ChamberLink:
        c = self.config.chamber
        return ChamberLink(self.server.url, profile=c.profile, clock=self.clock, timeout=c.timeout_s,
                           poll_interval=c.poll_s)


class RealThermalRig:
    """The configured rig and chamber on the real clock; the chamber's lock held while the session runs."""

    def __init__(self, config: RigConfig, spec: RigSpec) -> None:
        self.config = config
        self.clock = RealClock()
        self._stack = contextlib.ExitStack()

    def __enter__(self) -> "RealThermalRig":
        self._stack.enter_context(chamber_lock(self.config.chamber.url))
        return self

    def __exit__(self, *exc) -> None:
        self._stack.close()

    def build_rig(self, config: RigConfig, spec) -> assembly.Rig:
        return assembly.build_rig(config, spec)

    def chamber(self) -> ChamberLink:
        c = self.config.chamber
        return ChamberLink(c.url, profile=c.profile, clock=self.clock, timeout=c.timeout_s, poll_interval=c.poll_s)


def open_thermal_rig(config: RigConfig, spec: RigSpec):
    """The `procedures.thermal_session.HardwareFactory`: simulated for a simulated spec, else real."""
    return SimulatedThermalRig(config, spec) if spec.simulated else RealThermalRig(config, spec)


def run_thermal_to(out: Path, config: RigConfig | None, *, sim: bool = False, seed: int = 0,
                   time_scale: float | None = None, method: str = "joint", progress: bool = True,
                   resume: bool = False, plots: bool | None = None, echo=click.echo,
                   open_hardware=open_thermal_rig) -> int:
    """Run (or, with `resume`, finish) the thermal session in `out`, print its steps and end; the exit code."""
    bar = _Progress(progress)

    def events(kind: str, data: dict) -> None:
        bar.close()
        if kind == "soaked":
            s = data["soak"]
            done = (f"ramping at {s.ramp_c_per_min:+g} C/min towards {s.set_point_c:g} C after" if s.ramp_c_per_min
                    else f"soaked at {s.set_point_c:g} C in")
            echo(f"step {data['step'] + 1}/{data['steps']}: {done} {s.duration_s:.0f} s "
                 f"(die {s.die_c:.2f} C, slope {s.slope_c_per_min:+.3f} C/min)")
        elif kind == "step":
            step = data["data"]
            echo(f"step {data['step'] + 1}/{data['steps']}: recorded at {step['set_point_c']:g} C in "
                 f"{step['folder']}, verdict {step.get('verdict')}")

    session = ThermalSession(out, open_hardware, method=method, progress=bar, plots=plots, events=events)
    with late_stop_signals() as late:
        try:
            with stop_signals_raise():
                try:
                    outcome = session.resume() if resume else session.start(
                        config, RigSpec(sim, seed if sim else None, time_scale))
                finally:
                    bar.close()
        except KeyboardInterrupt as exc:
            signum = getattr(exc, "signum", signal.SIGINT)
            echo(f"aborted by {_signal_name(signum)} before the thermal session began; nothing new was recorded",
                 err=True)
            return aborted(signum)
        except Exception as exc:
            if not _is_known(exc):
                raise
            raise command_error(exc, prefix="" if resume else "cannot start the thermal session: ") from None
        code = show_thermal_outcome(outcome, echo)
    if late:
        echo(f"{_signal_name(late[0])} came after the session had ended ({outcome.status}): nothing left to stop",
             err=True)
    return code


def show_thermal_outcome(outcome: ThermalOutcome, echo=click.echo) -> int:
    out = outcome.folder
    for line in outcome.lines:
        echo(line)
    for line in outcome.warnings:
        echo(f"warning: {line}", err=True)
    if outcome.status == "aborted":
        echo(f"\naborted: {plain(outcome.reason)}; finish with: rig resume {out}", err=True)
        return aborted(outcome.signum)
    if outcome.status == "failed":
        echo(f"thermal session failed: {plain(outcome.reason)} (what was recorded is kept in {out}; "
             f"`rig resume {out}` continues)", err=True)
        if outcome.error_log is not None:
            return Exit.INTERNAL
        return code_for(outcome.error) if outcome.error is not None else Exit.FAILED
    echo("wrote " + " and ".join(str(p) for p in outcome.written))
    if outcome.verdict == "FAIL":
        echo(f"verdict: FAIL ({plain(outcome.reason)}); the thermal session is stored as rejected", err=True)
        return Exit.FAIL
    echo(f"verdict: {outcome.verdict}" + (" (no limits configured)" if outcome.verdict == "NOT CHECKED" else ""))
    return Exit.OK


def thermal_config(sim: bool, config_path, orientations) -> RigConfig:
    """`--thermal`: the configuration's [thermal] section, or the built-in thermal one under --sim alone."""
    if config_path is None:
        if not sim:
            raise click.UsageError("--thermal needs --sim (the built-in simulated thermal rig) or --config with a "
                                   "[thermal] section")
        config = builtin_thermal_config()
    else:
        try:
            config = load_config(config_path)
        except ValueError as e:
            raise CommandError(plain(str(e)), Exit.BAD_INPUT) from None
        if config.thermal is None:
            raise CommandError(f"{config_path}: --thermal needs a [thermal] section (its set points and soak)",
                               Exit.BAD_INPUT)
    if orientations:
        raise click.UsageError("--orientations: a thermal session's schedule size is [thermal] orientations")
    if config.chamber is None:
        raise CommandError(f"{config.source}: a thermal session needs a [chamber] section", Exit.BAD_INPUT)
    return config

