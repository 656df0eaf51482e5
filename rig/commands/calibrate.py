"""`rig calibrate`, `rig resume`: run a session (real or simulated) or calibrate recorded data."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from procedures.slot_session import slot_folders
from rig.commands.common import mirrored, read_any_session, rig_config, run_session_to
from rig.commands.plan import bus_budget
from rig.commands.importing import initial_rest_option, sensor_units, units_option
from rig.exits import CommandError, Exit, FiniteFloat, command_error, plain


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
@click.option("--thermal", is_flag=True,
              help="A thermal session: soak at each temperature step of [thermal] (the built-in thermal "
                   "configuration with --sim alone), a session per step, one temperature model. A --config with a "
                   "[thermal] section runs one without it.")
def calibrate(sim, config_path, from_dir, fmt, accel, gyro, units, initial_rest_s, out, seed, time_scale, method,
              orientations, gravity, settle_s, gyro_samples, holds_only, store, no_progress, plots, force, budget_s,
              target_h_pct, noise_from, thermal):
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
        from rig.commands.common import is_rig_session, session_kind
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
    if thermal:
        from rig.commands.thermal_run import thermal_config

        config = thermal_config(sim, config_path, orientations)
    else:
        config = rig_config(config_path, orientations)
    bus_budget(config)              # a rate the buses cannot carry is refused (exit 2) before anything moves
    if config.thermal is not None:
        from rig.commands.thermal_run import run_thermal_to

        if budget_s is not None or target_h_pct is not None or noise_from is not None:
            raise click.UsageError("--budget-s, --target-h-pct and --noise-from plan one session; a thermal "
                                   "session's steps take [thermal] orientations and hold_s")
        if config.chamber is None:
            raise CommandError(f"{config.source}: a thermal session needs a [chamber] section", Exit.BAD_INPUT)
        with mirrored(out, store or config.store.get("url")):
            code = run_thermal_to(out, config, sim=sim, seed=seed, time_scale=time_scale, method=method,
                                  progress=not no_progress, plots=plots)
        sys.exit(code)
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
    with mirrored(out, store or config.store.get("url"), [out / slot.name for slot in config.slots]):
        code = run_session_to(out, config, sim=sim, seed=seed, time_scale=time_scale, method=method,
                              progress=not no_progress, plots=plots, plan=plan)
    sys.exit(code)


def _calibrate_rig_folder(folder: Path, out: Path, *, method: str, settle_s: float, gravity: float | None,
                          gyro_samples: str, move_samples: bool = True) -> None:
    """`calibrate --from` on the rig's own session folder (no export needed): the same pipeline and writer."""
    from rig.commands.export import unfinished
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
    if (session.resolve().parent / "thermal.json").is_file():
        raise CommandError(f"{session}: a step of the thermal session in {session.resolve().parent}; resume that "
                           f"(`rig resume {session.parent}`), which soaks the step's temperature again first",
                           Exit.BAD_INPUT)
    with mirrored(session, store, slot_folders(session)):
        if (session / "thermal.json").is_file():         # procedures.thermal_session.MANIFEST
            from rig.commands.thermal_run import run_thermal_to

            code = run_thermal_to(session, None, method=method, progress=not no_progress, resume=True, plots=plots)
        else:
            code = run_session_to(session, None, method=method, progress=not no_progress, resume=True, plots=plots)
    sys.exit(code)
