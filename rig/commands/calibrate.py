"""`rig calibrate`, `rig resume`: run a session (real or simulated) or calibrate recorded data."""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import click

from rig import exits
from rig.commands.importing import initial_rest_option, sensor_units, units_option
from rig.config import RigConfig, load_config
from rig.exits import (
    CommandError,
    Exit,
    FiniteFloat,
    aborted,
    code_for,
    command_error,
    plain,
    stop_signal_numbers,
    stop_signals_raise,
)


class _Progress:
    """The tqdm bar of a session, made on the first report (a resumed session's length is known only then)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled, self.bar = enabled, None

    def __call__(self, k: int, n: int, phase: str) -> None:
        if not self.enabled:
            return
        if self.bar is None:
            from tqdm import tqdm

            self.bar = tqdm(total=n, unit="orientation", desc="calibration", file=sys.stderr,
                            bar_format="{desc}: {n}/{total} {bar} [{elapsed}<{remaining}] {postfix}")
        self.bar.n = k
        self.bar.set_postfix_str(f"orientation {min(k + 1, n)}/{n} {phase}")
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def build_rig(config: RigConfig, spec):
    """The orchestrator's rig factory (`rig.assembly.build_rig`), loaded when a session runs: `calibrate --from`
    never needs the simulated hardware or the turntable link."""
    from rig import assembly

    return assembly.build_rig(config, spec)


def run_session_to(out: Path, config: RigConfig | None, *, sim: bool = False, seed: int = 0,
                   time_scale: float | None = None, method: str = "joint", progress: bool = True,
                   resume: bool = False, trial: int = 0, plots: bool | None = None, plan: dict | None = None,
                   echo=click.echo) -> int:
    """Run (or, with `resume`, finish) the session in `out` and show how it ended; returns the exit code.

    The orchestrator does the work; here are the progress bar, the stop signals and the exit code.
    """
    from procedures.orchestrator import RigSpec, SessionOrchestrator

    bar = _Progress(progress)
    orchestrator = SessionOrchestrator(out, build_rig, method=method, progress=bar, plots=plots)
    with late_stop_signals() as late:         # what the session's stop handler leaves behind: noted, not obeyed
        try:
            with stop_signals_raise():
                try:
                    if resume:
                        outcome = orchestrator.resume()
                    else:
                        outcome = orchestrator.start(config, RigSpec(sim, seed if sim else None, time_scale, trial),
                                                     plan)
                finally:
                    bar.close()
        except KeyboardInterrupt as exc:      # a stop before the session existed: nothing to mark
            import signal

            signum = getattr(exc, "signum", signal.SIGINT)
            echo(f"aborted by {_signal_name(signum)} before recording began; nothing new was recorded", err=True)
            return aborted(signum)
        except Exception as exc:
            if not _is_known(exc):
                raise
            raise command_error(exc, prefix="" if resume else "cannot start the session: ") from None
        code = show_outcome(outcome, echo)
    if late:
        echo(f"{_signal_name(late[0])} came after the session had ended ({outcome.status}): nothing left to stop",
             err=True)
    return code


@contextlib.contextmanager
def late_stop_signals():
    """A stop signal once the session has ended and its status is stored is noted, not obeyed: the exit code
    stays the one of the session's stored end (a SIGTERM racing a failed session's exit killed the process with
    the signal's code while the store said `failed`; found by the fault campaign). In the `rig` process itself
    the note stays until the process exits, since a signal between this block and the exit would kill it with
    the signal's code all the same; inside another program the handlers are given back."""
    import signal

    late: list[int] = []
    before = {sig: signal.signal(sig, lambda signum, frame: late.append(signum)) for sig in stop_signal_numbers()}
    try:
        yield late
    finally:
        if not exits.process_ends_with_command:
            for sig, old in before.items():
                signal.signal(sig, old)


def _signal_name(signum: int) -> str:
    from rig.errors import signal_name

    return signal_name(signum)


def _is_known(exc: BaseException) -> bool:
    from rig.errors import RigError

    return isinstance(exc, (RigError, OSError)) or type(exc).__module__.startswith("drivers")


def show_outcome(outcome, echo=click.echo) -> int:
    """Print the end of a session (summary, warnings, truth, verdict or the reason it stopped); its exit code."""
    out = outcome.folder
    if outcome.status == "aborted":
        echo(f"\naborted: {outcome.reason}; {outcome.holds}/{outcome.n_holds} holds recorded in {out}; "
             f"finish with: rig resume {out}", err=True)
        return aborted(outcome.signum)
    if outcome.status == "failed":
        echo(f"session failed: {plain(outcome.reason)} ({outcome.holds}/{outcome.n_holds} holds are kept in {out}; "
             f"`rig resume {out}` continues)", err=True)
        if outcome.error_log is not None:            # not a known fault: a bug, its traceback in the log
            return Exit.INTERNAL
        return code_for(outcome.error) if outcome.error is not None else Exit.FAILED
    for line in outcome.summary:
        echo(line)
    for line in outcome.warnings:
        echo(f"warning: {line}", err=True)
    for line in outcome.truth_lines:
        echo(line)
    echo("wrote " + " and ".join(str(p) for p in outcome.written))
    if outcome.verdict == "FAIL":
        echo(f"verdict: FAIL ({plain(outcome.reason.removeprefix('verdict FAIL: '))}); the session is stored as "
             "rejected", err=True)
        return Exit.FAIL
    echo(f"verdict: {outcome.verdict}" + (" (no limits configured)" if outcome.verdict == "NOT CHECKED" else ""))
    return Exit.OK


@click.command()
@click.option("--sim", is_flag=True, help="Run on the built-in simulated rig (fake chips, fake turntable).")
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False), help="Rig TOML file.")
@click.option("--from", "from_dir", type=click.Path(exists=True, file_okay=False),
              help="Calibrate a recorded session (the rig's own folder or an interchange one) instead of running one.")
@click.option("--format", "fmt", type=click.Choice(["interchange", "imu_tk"]), default="interchange",
              show_default=True)
@click.option("--accel", type=click.Path(exists=True, dir_okay=False), help="imu_tk accelerometer file.")
@click.option("--gyro", type=click.Path(exists=True, dir_okay=False), help="imu_tk gyroscope file.")
@units_option
@initial_rest_option
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path), help="Output folder.")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True,
              help="Simulated unit and noise (with --sim).")
@click.option("--time-scale", type=FiniteFloat(0, 1e6, low_open=True), default=None,
              help="Run the simulated rig at X times real time.")
@click.option("--method", type=click.Choice(["joint", "two-step"]), default="joint", show_default=True,
              help="Accelerometer/magnetometer estimator.")
@click.option("--orientations", type=click.IntRange(9, 64), default=None, help="Override the schedule size.")
@click.option("--gravity", type=FiniteFloat(1.0, 30.0), default=None,
              help="Local gravity in m/s^2 for imu_tk data (default 9.80665; interchange sessions carry their own).")
@click.option("--settle-s", type=FiniteFloat(0.0, 3600.0), default=0.5, show_default=True,
              help="With --from: seconds dropped at the start of each hold (settling).")
@click.option("--gyro-samples", type=click.Choice(["auto", "point", "mean"]), default="auto", show_default=True,
              help="With --from: a gyro sample is the rate at its time stamp (point) or its mean over the sample "
                   "period (mean); auto fits both and keeps the one that matches the known rotations better.")
@click.option("--holds-only", is_flag=True,
              help="With --from: accelerometer and magnetometer from the hold means alone, not the move samples too.")
@click.option("--store", "store", default=None, metavar="URL|FOLDER",
              help="The lab's store ([store] url in the TOML): a postgresql:// URL the session is mirrored into as "
                   "it runs (recorded locally first; `rig push` finishes what the network kept back), or a folder "
                   "of session folders that --out must lie in.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
@click.option("--plots/--no-plots", default=None,
              help="Draw the report's figures after the result is written (default: on a real rig, not with --sim).")
@click.option("--force", is_flag=True, help="With --from: replace a calibration.json already in --out (its "
              "report.md is written again to match).")
@click.option("--budget-s", type=FiniteFloat(1.0, 36000.0), default=None,
              help="Run the plan of `rig plan --budget-s`: the most accurate that fits this table time.")
@click.option("--target-h-pct", type=FiniteFloat(0.0, 100.0, low_open=True), default=None,
              help="Run the plan of `rig plan --target-h-pct`: the shortest predicted to reach this H error.")
@click.option("--noise-from", type=click.Path(exists=True, file_okay=False), default=None,
              help="With --budget-s/--target-h-pct: the noise of a calibrated session of this unit.")
def calibrate(sim, config_path, from_dir, fmt, accel, gyro, units, initial_rest_s, out, seed, time_scale, method,
              orientations, gravity, settle_s, gyro_samples, holds_only, store, no_progress, plots, force, budget_s,
              target_h_pct, noise_from):
    """Run a calibration session and compute B and H of every sensor (or calibrate recorded data)."""
    if fmt != "imu_tk" and (units is not None or initial_rest_s is not None):
        raise click.UsageError("--units and --initial-rest-s say how imu_tk's files are read (--format imu_tk); a "
                               "session carries its own")
    if from_dir or fmt == "imu_tk":
        if budget_s is not None or target_h_pct is not None or noise_from is not None:
            raise click.UsageError("--budget-s, --target-h-pct and --noise-from plan a session to run; a recorded "
                                   "one (--from, --format imu_tk) is calibrated as it was recorded")
        from rig.pipeline import calibrate_from_dir

        if fmt == "imu_tk" and not (accel and gyro):
            raise click.UsageError("--format imu_tk needs --accel FILE and --gyro FILE")
        from rig.commands.sessions import is_rig_session, read_any_session, session_kind
        from rig.errors import RigError
        from rig.recording_kinds import refuse_unless_taken

        from rig.commands.export import recording_holder
        from rig.report.recalibrated import refuse_overwrite, report_again

        try:
            kind = session_kind(Path(from_dir)) if fmt == "interchange" else None
            if kind is not None:
                refuse_unless_taken("calibrate", *kind, from_dir)
            if recording_holder(out) is not None:
                raise CommandError(f"--out {out}: a session is being recorded there by {recording_holder(out)}",
                                   Exit.BUSY)
            refuse_overwrite(out, force)
            if fmt == "interchange" and is_rig_session(from_dir):
                if click.get_current_context().get_parameter_source("settle_s").name == "DEFAULT":
                    settle_s = 0.0                  # the rig records a hold once the table has settled
                _calibrate_rig_folder(Path(from_dir), out, method=method, settle_s=settle_s, gravity=gravity,
                                      gyro_samples=gyro_samples, move_samples=not holds_only)
                return
            result = calibrate_from_dir(from_dir, out, fmt=fmt, accel_file=accel, gyro_file=gyro, method=method,
                                        settle_s=settle_s, gravity=gravity, gyro_samples=gyro_samples,
                                        echo=click.echo, move_samples=not holds_only,
                                        units=sensor_units(units, ["accel", "gyro"]) if fmt == "imu_tk" else None,
                                        initial_rest_s=initial_rest_s)
            said = report_again(out, read_any_session(Path(from_dir)) if fmt == "interchange" else None,
                                result.sensors) if force else None
            if said:
                click.echo(said)
        except (RigError, OSError) as e:
            raise command_error(e) from None
        except (ValueError, ArithmeticError) as e:     # numbers the data cannot support (numpy's LinAlgError too)
            raise CommandError(f"{from_dir or accel}: the data cannot be calibrated: {plain(str(e))}") from None
        if result.refused:                              # written without them: a check did not pass
            sys.exit(Exit.FAIL)
        return
    if not sim and not config_path:
        raise click.UsageError("give --sim (simulated rig), --config rig.toml (real rig) or --from SESSION_DIR")
    if time_scale is not None and not sim:
        raise click.UsageError("--time-scale applies to --sim only")
    config = _config(config_path, orientations)
    plan = None
    if budget_s is not None or target_h_pct is not None:
        from rig.commands.plan import planned_config, predicted_lines, refuse_orientations_with_planner

        if budget_s is not None and target_h_pct is not None:
            raise click.UsageError("give --budget-s or --target-h-pct, not both")
        refuse_orientations_with_planner(orientations, budget_s, target_h_pct)
        config, chosen, default, _ = planned_config(config, budget_s, target_h_pct, noise_from)
        click.echo(f"plan: {chosen.orientations} orientations, holds of {chosen.hold_s} s, moves at up to "
                   f"{chosen.speed_dps:g} deg/s; estimated rig time {chosen.eta_s:.0f} s; predicted:")
        for line in predicted_lines(chosen, default):
            click.echo(line)
        plan = chosen.to_dict()
    elif noise_from is not None:
        raise click.UsageError("--noise-from goes with --budget-s or --target-h-pct")
    with mirrored(out, store or config.store.get("url")):
        code = run_session_to(out, config, sim=sim, seed=seed, time_scale=time_scale, method=method,
                              progress=not no_progress, plots=plots, plan=plan)
    sys.exit(code)


@contextlib.contextmanager
def mirrored(out: Path, store: str | None):
    """The session recorded in `out` and, with a database store, mirrored into it while it runs (rig.lab.mirror:
    the rig never waits for the network); a folder store is where session folders lie, so `out` must be in it."""
    if store is None:
        yield
        return
    from rig.lab.errors import is_database_url

    if not is_database_url(store):
        if not Path(out).resolve().is_relative_to(Path(store).resolve()):
            raise CommandError(f"--store {store}: a folder store holds session folders, and {out} is not inside it "
                               f"(e.g. {Path(store) / Path(out).name})", Exit.BAD_INPUT)
        yield
        return
    try:
        from rig.lab.mirror import live_mirror
    except ModuleNotFoundError as exc:
        raise CommandError(f"--store {store}: the lab's store needs the package {exc.name!r}: "
                           "pip install 'rig[lab]'", Exit.BAD_INPUT) from None
    with live_mirror(out, store):
        yield


def _calibrate_rig_folder(folder: Path, out: Path, *, method: str, settle_s: float, gravity: float | None,
                          gyro_samples: str, move_samples: bool = True) -> None:
    """`calibrate --from` on the rig's own session folder (no export needed): the same pipeline and writer."""
    from rig.commands.export import unfinished
    from rig.commands.sessions import read_any_session
    from rig.pipeline import calibrate_session
    from rig.pipeline.writing import write_session_calibration
    from rig.report.recalibrated import report_again

    session = read_any_session(folder)
    warning = unfinished(folder, session.meta, "this calibration", len(session.hold_rows()))
    if warning:
        click.echo(warning, err=True)
    if gravity is not None:
        session.gravity = float(gravity)
    result = calibrate_session(session, method=method, settle_s=settle_s, gyro_samples=gyro_samples,
                               move_samples=move_samples)
    unit = session.meta.get("unit") or {}
    path = write_session_calibration(out, result, gravity=session.gravity, field_uT=session.field_uT,
                                     unit_serial=unit.get("serial"), board=unit.get("board"),
                                     extra={"source": {"format": "rig-session-sqlite/1", "path": str(folder),
                                                       "method": method, "settle_s": settle_s,
                                                       "gyro_samples": gyro_samples, "move_samples": move_samples}},
                                     session=session)
    for line in result.summary:
        click.echo(line)
    for w in result.warnings:
        click.echo(f"warning: {w}")
    click.echo(f"wrote {path}")
    said = report_again(out, session, result.sensors)
    if said:
        click.echo(said)


def _config(path, orientations) -> RigConfig:
    try:
        config = load_config(path)
    except ValueError as e:
        raise CommandError(plain(str(e)), Exit.BAD_INPUT) from None
    if orientations:
        config.schedule.orientations = orientations
    return config


@click.command()
@click.argument("session", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--method", type=click.Choice(["joint", "two-step"]), default="joint", show_default=True)
@click.option("--store", "store", default=None, metavar="URL",
              help="Mirror the session into the lab's postgresql:// store as it runs (as calibrate --store).")
@click.option("--no-progress", is_flag=True)
@click.option("--plots/--no-plots", default=None,
              help="Draw the report's figures after the result is written (default: on a real rig, not on the "
                   "simulated one).")
def resume(session, method, store, no_progress, plots):
    """Finish an interrupted session: hold again at its last recorded orientation, record the rest, calibrate.

    Refused (exit 4) while another process works on the session or its turntable."""
    with mirrored(session, store):
        code = run_session_to(session, None, method=method, progress=not no_progress, resume=True, plots=plots)
    sys.exit(code)
