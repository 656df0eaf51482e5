"""`rig calibrate`, `rig resume`, `rig plan`: run a session (real or simulated) or calibrate recorded data."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from rig.config import RigConfig, config_from_dict, load_config


def _progress_bar(total: int, enabled: bool):
    from tqdm import tqdm

    bar = tqdm(total=total, unit="orientation", desc="calibration", disable=not enabled, file=sys.stderr,
               bar_format="{desc}: {n}/{total} {bar} [{elapsed}<{remaining}] {postfix}")

    def progress(k: int, n: int, phase: str) -> None:
        bar.n = k
        bar.set_postfix_str(f"orientation {min(k + 1, n)}/{n} {phase}")
        bar.refresh()

    return bar, progress


def _terminate_as_interrupt(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


def run_session_to(out: Path, config: RigConfig, *, sim: bool, seed: int, time_scale: float | None,
                   method: str, progress: bool, resume: bool = False, trial: int = 0) -> int:
    """Record (or finish recording) a session in `out`, then calibrate and report. Returns the exit status.

    SIGTERM and SIGHUP are handled like Ctrl-C: the table is stopped and disabled, the session marked aborted.
    """
    import signal

    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _terminate_as_interrupt)
    from procedures.session import check_plan, plan_for, record, session_metadata, write_json
    from rig.assembly import build_real, build_sim, truth_after_start
    from rig.store import SessionStore

    if resume:
        store = SessionStore.open(out)
        meta = store.metadata
        from procedures.planning import Orientation
        schedule = [Orientation(**o) for o in meta["schedule"]]
        done = store.completed_holds()
        start = (max(done) + 1) if done else 0
        if start >= len(schedule):
            click.echo(f"{out}: all {len(schedule)} holds are recorded; calibrating")
    else:
        schedule = plan_for(config)
        problems = check_plan(config, schedule)
        if problems:
            raise click.ClickException("the schedule cannot excite every axis: " + "; ".join(problems))
        store, start = None, 0
    rig = build_sim(config, seed=seed, trial=trial, time_scale=time_scale) if sim else build_real(config)
    with rig:
        rig.board.start()
        truth = truth_after_start(rig)
        if store is None:
            meta = session_metadata(config, schedule, sim=sim, seed=seed if sim else None, time_scale=time_scale)
            meta["trial"] = trial
            meta["chips"] = rig.board.settings()
            if truth is not None:
                meta["truth"] = truth
            store = SessionStore.create(out, meta)
            if truth is not None:
                write_json(out / "truth.json", truth)
        bar, prog = _progress_bar(len(schedule), progress)
        try:
            if start < len(schedule):
                store.set_status("running", "resumed" if resume else "")
                t0 = store.last_time() + 1.0 if resume and store.last_time() is not None else 0.0
                stats = record(rig, store, schedule, start_step=start, session_t0=t0, progress=prog)
                store.update_metadata(acquisition=stats)
        except KeyboardInterrupt:
            bar.close()
            store.set_status("aborted", "interrupted by the operator (SIGINT); the table was stopped and disabled")
            click.echo(f"\naborted: {len(store.completed_holds())}/{len(schedule)} holds recorded in {out}; "
                       f"finish with: rig resume {out}", err=True)
            return 130
        except Exception as e:
            bar.close()
            store.set_status("failed", f"{type(e).__name__}: {e}")
            raise click.ClickException(f"session failed: {e} (recorded holds are kept in {out}; "
                                       f"`rig resume {out}` continues)") from e
        bar.close()
    return finish_session(out, store, method=method)


def finish_session(out: Path, store, *, method: str, settle_s: float = 0.0) -> int:
    """Calibrate the recorded session, write calibration.json and the report, mark the session complete.

    Holds are recorded after the table settled, so nothing is dropped from their start by default.
    """
    from rig.pipeline import calibrate_session
    from rig.pipeline.writing import write_session_calibration
    from rig.report import write_report

    from rig.errors import CalibrationError

    meta = store.metadata
    session = store.to_session_data()
    try:
        result = calibrate_session(session, method=method, settle_s=settle_s)
    except CalibrationError as e:
        store.set_status("failed", f"calibration: {e}")
        raise click.ClickException(f"{out}: the recorded session cannot be calibrated: {e}") from None
    unit = meta.get("unit", {})
    write_session_calibration(out, result, gravity=session.gravity, field_uT=session.field_uT,
                              unit_serial=unit.get("serial"), board=unit.get("board"), extra={"session": str(out)})
    truth = meta.get("truth")
    limits = (meta.get("config") or {}).get("limits")
    report = write_report(out, session, result.sensors, gravity=session.gravity, field_uT=session.field_uT,
                          truth=truth, limits=limits, metadata={**store.metadata, "status": "complete"})
    store.update_metadata(calibration="calibration.json", report=report.name)
    store.set_status("complete", "")
    for line in result.summary:
        click.echo(line)
    for line in result.warnings:
        click.echo(f"warning: {line}", err=True)
    if truth:
        for line in truth_errors(result.sensors, truth):
            click.echo(line)
    click.echo(f"wrote {out / 'calibration.json'} and {report}")
    return 0


def truth_errors(sensors: dict, truth: dict) -> list[str]:
    import numpy as np

    lines = []
    for name, cal in sensors.items():
        t = truth["sensors"].get(name)
        if not t:
            continue
        H, B = np.array(t["H"]), np.array(t["B"])
        eH = np.linalg.norm(cal.H - H) / np.linalg.norm(H) * 100
        eB = np.linalg.norm(cal.B - B) / max(np.linalg.norm(B), 1e-12) * 100
        lines.append(f"{name}: against the simulator's truth: H error {eH:.4f} % (Frobenius), B error {eB:.4f} %")
    return lines


@click.command()
@click.option("--sim", is_flag=True, help="Run on the built-in simulated rig (fake chips, fake turntable).")
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False), help="Rig TOML file.")
@click.option("--from", "from_dir", type=click.Path(exists=True, file_okay=False),
              help="Calibrate a recorded interchange session instead of running one.")
@click.option("--format", "fmt", type=click.Choice(["interchange", "imu_tk"]), default="interchange",
              show_default=True)
@click.option("--accel", type=click.Path(exists=True, dir_okay=False), help="imu_tk accelerometer file.")
@click.option("--gyro", type=click.Path(exists=True, dir_okay=False), help="imu_tk gyroscope file.")
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path), help="Output folder.")
@click.option("--seed", type=int, default=0, show_default=True, help="Simulated unit and noise (with --sim).")
@click.option("--time-scale", type=float, default=None, help="Run the simulated rig at X times real time.")
@click.option("--method", type=click.Choice(["joint", "two-step"]), default="joint", show_default=True,
              help="Accelerometer/magnetometer estimator.")
@click.option("--orientations", type=click.IntRange(9, 64), default=None, help="Override the schedule size.")
@click.option("--gravity", type=float, default=None,
              help="Local gravity in m/s^2 for imu_tk data (default 9.80665; interchange sessions carry their own).")
@click.option("--settle-s", type=float, default=0.5, show_default=True,
              help="With --from: seconds dropped at the start of each hold (settling).")
@click.option("--gyro-samples", type=click.Choice(["auto", "point", "mean"]), default="auto", show_default=True,
              help="With --from: a gyro sample is the rate at its time stamp (point) or its mean over the sample "
                   "period (mean); auto fits both and keeps the one that matches the known rotations better.")
@click.option("--no-progress", is_flag=True, help="No progress bar.")
def calibrate(sim, config_path, from_dir, fmt, accel, gyro, out, seed, time_scale, method, orientations,
              gravity, settle_s, gyro_samples, no_progress):
    """Run a calibration session and compute B and H of every sensor (or calibrate recorded data)."""
    if from_dir or fmt == "imu_tk":
        from rig.pipeline import calibrate_from_dir

        if fmt == "imu_tk" and not (accel and gyro):
            raise click.UsageError("--format imu_tk needs --accel FILE and --gyro FILE")
        try:
            calibrate_from_dir(from_dir, out, fmt=fmt, accel_file=accel, gyro_file=gyro, method=method,
                               settle_s=settle_s, gravity=gravity, gyro_samples=gyro_samples, echo=click.echo)
        except ValueError as e:
            raise click.ClickException(str(e)) from None
        return
    if not sim and not config_path:
        raise click.UsageError("give --sim (simulated rig), --config rig.toml (real rig) or --from SESSION_DIR")
    if time_scale is not None and not sim:
        raise click.UsageError("--time-scale applies to --sim only")
    config = _config(config_path, orientations)
    sys.exit(run_session_to(out, config, sim=sim, seed=seed, time_scale=time_scale, method=method,
                            progress=not no_progress))


def _config(path, orientations) -> RigConfig:
    try:
        config = load_config(path)
    except ValueError as e:
        raise click.ClickException(str(e)) from None
    if orientations:
        config.schedule.orientations = orientations
    return config


@click.command()
@click.argument("session", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--method", type=click.Choice(["joint", "two-step"]), default="joint", show_default=True)
@click.option("--no-progress", is_flag=True)
def resume(session, method, no_progress):
    """Finish an interrupted session from the next orientation, then calibrate."""
    from rig.store import SessionStore

    meta = SessionStore.open(session).metadata
    if meta.get("status") == "complete":
        raise click.ClickException(f"{session}: the session is already complete")
    config = config_from_dict(meta["config"])
    sys.exit(run_session_to(session, config, sim=bool(meta.get("simulated")), seed=meta.get("seed") or 0,
                            time_scale=meta.get("time_scale"), method=method, progress=not no_progress,
                            resume=True, trial=meta.get("trial") or 0))


@click.command()
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False))
@click.option("--orientations", type=click.IntRange(9, 64), default=None)
def plan(config_path, orientations):
    """Dry run: the schedule, its observability and the ETA. Nothing moves."""
    from procedures.planning import estimate_duration
    from procedures.session import check_plan, plan_for

    config = _config(config_path, orientations)
    schedule = plan_for(config)
    t, s = config.turntable, config.schedule
    click.echo(f"{len(schedule)} orientations on a {config.board} board, holds of {s.hold_s} s at {s.rate_hz} Hz")
    click.echo("  #   outer_deg   inner_deg")
    for k, o in enumerate(schedule):
        click.echo(f"{k:3d} {o.outer_deg:11.3f} {o.inner_deg:11.3f}")
    problems = check_plan(config, schedule)
    click.echo("observability: " + ("every axis excited" if not problems else "; ".join(problems)))
    eta = estimate_duration(schedule, hold_s=s.hold_s, speed_dps=t.speed_dps, accel_dps2=t.accel_dps2,
                            settle_s=t.settle_s)
    click.echo(f"estimated rig time: {eta:.0f} s ({eta / 60:.1f} min)")
    if problems:
        sys.exit(1)
