"""`rig attitude` (the filter on a recorded session) and `rig validate` (Table III on the turntable)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from rig.exits import CommandError, Exit, command_error, plain, stop_signals_raise

MAG_CHOICE = click.Choice(["vector", "heading"])


def _settings(mag_measurement: str, no_still_detection: bool = False):
    from rig.attitude.ukf import UKFSettings

    return UKFSettings(mag_measurement=mag_measurement, still=None if no_still_detection else UKFSettings().still)


NO_STILL_HELP = "Integrate the gyro on every step (the paper's filter) instead of taking still steps as zero rate."


def _fail(e: Exception) -> click.ClickException:
    """A RigError with its exit code; any other ValueError here is a number the data cannot support."""
    from rig.errors import RigError

    if isinstance(e, RigError):
        return command_error(e)
    if isinstance(e, OSError) and e.strerror:
        return CommandError(f"{e.filename + ': ' if e.filename else ''}{e.strerror}")
    return CommandError(plain(str(e)))


@click.command()
@click.argument("session_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--calibration", required=True, type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="calibration.json to apply (u = H (y - B)).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path),
              help="Write the RMS errors and the comparison table as JSON.")
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), help="Also write report.md and plots here.")
@click.option("--mag-measurement", type=MAG_CHOICE, default="vector", show_default=True,
              help="Magnetometer as the field direction (vector) or as heading only (the paper's).")
@click.option("--no-peers", is_flag=True, help="Skip the ahrs Madgwick/Mahony/EKF peers.")
@click.option("--no-still-detection", is_flag=True, help=NO_STILL_HELP)
def attitude(session_dir, calibration, json_out, out, mag_measurement, no_peers, no_still_detection):
    """Run the quaternion UKF on a session with motion (the rig's folder or an interchange one) and compare with
    its reference."""
    from procedures.validation import nominal_calibration, table3_markdown, validate_session, write_outputs
    from rig.attitude.evaluate import gyro_gaps, session_rows
    from rig.attitude.peers import PEERS
    from rig.errors import RigError
    from rig.commands.common import read_any_session
    from rig.io.calibration_json import read_calibration, triads_from_calibration

    try:
        session = read_any_session(session_dir)
        doc = read_calibration(calibration)
        ours = triads_from_calibration(doc)
        if session.field_uT is None and doc.get("field_uT") is not None:
            session.field_uT = float(doc["field_uT"])
        methods = ", ".join(sorted({c.method for c in ours.values()}))
        calibrations = {f"ours ({methods})": ours}
        nominal = nominal_calibration(session.meta.get("chips", {}))
        if {"gyro", "accel"} <= set(nominal):
            calibrations["nominal datasheet"] = nominal
        result = validate_session(session, calibrations, peers=() if no_peers else PEERS,
                                  settings=_settings(mag_measurement, no_still_detection))
        gaps = gyro_gaps(session, session_rows(session))
    except (RigError, ValueError) as e:
        raise _fail(e) from None
    extra = {"session": str(session_dir), "calibration": str(calibration), "mag_measurement": mag_measurement,
             "gyro_gaps": [{"t_s": t0, "seconds": length} for t0, length in gaps]}
    if out:
        doc_out = write_outputs(Path(out), result, session, title=f"Attitude of {session_dir}", extra=extra)
    else:
        doc_out = {**result.to_dict(), **extra}
    click.echo(table3_markdown(result))
    rms = doc_out["rms_deg"]
    click.echo("ours: RMS roll {roll:.3f}, pitch {pitch:.3f}, yaw {yaw:.3f} deg".format(**rms))
    for t0, length in gaps:
        click.echo(f"warning: the gyro has no samples for {length:.2f} s from t = {t0:.2f} s: the filters cross it on "
                   "the last rate, so the attitude after it carries what the table turned there")
    if json_out:
        Path(json_out).write_text(json.dumps(doc_out, indent=2) + "\n")
        click.echo(f"wrote {json_out}")


@click.command()
@click.option("--sim", is_flag=True, help="Run on the built-in simulated rig.")
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False), help="Rig TOML file.")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True,
              help="Simulated unit and noise (with --sim).")
@click.option("--calibration", type=click.Path(exists=True, dir_okay=False, path_type=Path),
              help="Use this calibration.json instead of running a calibration session first.")
@click.option("--method", type=click.Choice(["joint", "two-step"]), default="joint", show_default=True,
              help="Accelerometer/magnetometer estimator of the calibration session.")
@click.option("--mag-measurement", type=MAG_CHOICE, default="vector", show_default=True)
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path), help="Output folder.")
@click.option("--no-plots", is_flag=True)
@click.option("--no-still-detection", is_flag=True, help=NO_STILL_HELP)
def validate(sim, config_path, seed, calibration, method, mag_measurement, out, no_plots, no_still_detection):
    """Calibrate, run the dynamic trajectory on the same unit, and write the Table III attitude report."""
    from procedures.validation import validate_on_rig
    from rig.commands.common import build_rig
    from rig.config import load_config
    from rig.errors import RigError

    if not sim and not config_path:
        raise click.UsageError("give --sim (simulated rig) or --config rig.toml (real rig)")
    try:
        config = load_config(config_path)
    except ValueError as e:
        raise CommandError(plain(str(e)), Exit.BAD_INPUT) from None
    try:
        with stop_signals_raise():
            validate_on_rig(out, config, sim=sim, seed=seed, calibration=calibration, method=method,
                            plots=not no_plots, settings=_settings(mag_measurement, no_still_detection),
                            echo=click.echo, build_rig=build_rig)
    except (RigError, ValueError, OSError) as e:
        raise _fail(e) from None
