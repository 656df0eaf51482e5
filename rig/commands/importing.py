"""`rig import imu_tk|ferraris|csv`: a recording from another logger as an ordinary session folder.

The session (`imu-session-csv/1`, "Recordings without a turntable") is what every other command reads:
`rig calibrate --from DIR`, `rig discrepancy DIR`, `rig attitude DIR`.
"""

from __future__ import annotations

from pathlib import Path

import click

from rig.errors import InputError
from rig.exits import CommandError, Exit, FiniteFloat, command_error
from rig.io.recording import IMPORT_UNITS, parse_units

WRITTEN = ("meta.json", "samples.csv")
UNITS_HELP = ("Units the sensors' columns are in, e.g. accel=m/s^2,gyro=rad/s: "
              + "; ".join(f"{sensor} in {', '.join(units)}" for sensor, units in IMPORT_UNITS.items())
              + " (default: counts).")


def _out_option(f):
    f = click.option("--force", is_flag=True, help="Replace a session already in the --out folder.")(f)
    return click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path),
                        help="Session folder to write (meta.json + samples.csv).")(f)


def units_option(f):
    """`--units`: the one definition every importer takes (`rig import imu_tk|ferraris|csv`, `rig calibrate --format
    imu_tk`), read by `sensor_units`."""
    return click.option("--units", default=None, metavar="SENSOR=UNIT,...", help=UNITS_HELP)(f)


def sensor_units(text: str | None, sensors: list[str]) -> dict[str, str]:
    """`--units` as {sensor: unit} for the sensors an import reads (counts where not named); a sensor named that the
    import does not read is refused, as a unit that sensor cannot be in is (InputError, naming --units)."""
    units = parse_units(text, sensors)
    unread = [sensor for sensor in units if sensor not in sensors]
    if unread:
        raise InputError(f"--units names {' and '.join(unread)}, which this import does not read (it reads "
                         f"{', '.join(sensors)})")
    return units


def initial_rest_option(f):
    return click.option("--initial-rest-s", type=FiniteFloat(0, low_open=True), default=None,
                        help="Seconds of rest the recording starts with (imu_tk's initial static interval: the "
                        "static threshold and the gyro bias); by default found in the data: the still stretch the record "
                        "starts with, or, where it starts moving, the threshold from its quietest stretches and the "
                        "gyro bias from its poses.")(f)


def _gravity_option(f):
    return click.option("--gravity", type=FiniteFloat(0, low_open=True), default=9.80665, show_default=True,
                        help="Local gravity magnitude, m/s^2.")(f)


def _write(session, out: Path, force: bool) -> None:
    from rig.io.session_writer import write_session

    present = [name for name in WRITTEN if (out / name).exists()]
    if present and not force:
        raise CommandError(f"{out}: already holds {' and '.join(present)}; give --force to replace them, or another "
                           "--out", Exit.BAD_INPUT)
    try:
        write_session(session, out)
    except OSError as e:
        raise CommandError(f"{out}: cannot write the session: {e.strerror}", Exit.BAD_INPUT) from None
    segs = session.meta.get("segments") or []
    kinds = {k: sum(s["kind"] == k for s in segs) for k in ("static", "rotation")}
    units = ", ".join(f"{s} in {u}" for s, u in session.meta["units"].items())
    click.echo(f"wrote {out} ({len(session.t)} rows, {units}; {kinds['static']} static and {kinds['rotation']} "
               f"rotation segments)")
    for seg in segs:
        if seg["kind"] == "rotation":
            click.echo(f"  {seg['name']}: {seg['angle_deg']:+g} deg about {seg['axis']} "
                       f"(+/- {seg.get('angle_deg_sd', 0):g} deg, sense "
                       f"{session.meta['imported'].get('turn_sense', 'given')})")
    click.echo(recording_uses(list(session.raw)))


def recording_uses(sensors: list[str]) -> str:
    """Which commands take a recording of these sensors, and what the others lack (`rig.recording_kinds`)."""
    from rig.recording_kinds import COMMANDS, kind_name, use

    taken, not_taken = [], []
    for command in COMMANDS:
        u = use(command, False, sensors)
        if u.taken:
            taken.append(("rig calibrate --from" if command == "calibrate" else f"rig {command}")
                         + (f" ({u.note})" if u.note else ""))
        elif u.lacks_sensor:
            not_taken.append(f"rig {command} ({u.note})")
    line = (f"a recording of kind {kind_name(False, sensors)}: {', '.join(taken)} take"
            f"{'s' if len(taken) == 1 else ''} it")
    return line + (f"; not {', '.join(not_taken)}" if not_taken else "")


def _run(build, out: Path, force: bool) -> None:
    from rig.errors import RigError

    try:
        session = build()
    except RigError as e:
        raise command_error(e) from None
    _write(session, out, force)


def _columns(option: str, text: str | None) -> list[str] | None:
    if text is None:
        return None
    names = [c.strip() for c in text.split(",")]
    if len(names) != 3 or not all(names):
        raise click.BadParameter(f"{text!r}: three column names, x,y,z", param_hint=option)
    return names


@click.group("import")
def import_group() -> None:
    """A recording from another logger as a session folder every command accepts."""


@import_group.command("imu_tk")
@click.option("--accel", required=True, type=click.Path(dir_okay=False), help="imu_tk accelerometer file.")
@click.option("--gyro", required=True, type=click.Path(dir_okay=False), help="imu_tk gyroscope file.")
@click.option("--mag", type=click.Path(dir_okay=False), help="imu_tk magnetometer file.")
@click.option("--field-uT", "field_uT", type=FiniteFloat(0, low_open=True),
              help="Local field magnitude, uT (with --mag); without it the magnetometer is calibrated to the "
                   "magnitude its own samples show.")
@units_option
@initial_rest_option
@_gravity_option
@_out_option
def import_imu_tk(accel, gyro, mag, field_uT, units, initial_rest_s, gravity, out, force):
    """imu_tk ASCII files (timestamp x y z; raw counts, or the units --units names), sampled together."""
    from rig.io.import_imu_tk import import_imu_tk as build

    files = {"accel": accel, "gyro": gyro, **({"mag": mag} if mag else {})}
    _run(lambda: build(files, units=sensor_units(units, list(files)), gravity=gravity, field_uT=field_uT,
                       initial_rest_s=initial_rest_s), out, force)


@import_group.command("ferraris")
@click.option("--csv", "csv_file", type=click.Path(dir_okay=False), help="imucal continuous session CSV.")
@click.option("--sections", type=click.Path(dir_okay=False), help="imucal section list (JSON) of --csv.")
@click.option("--annotated", type=click.Path(dir_okay=False), help="imucal pre-cut session CSV (part, samples, ...).")
@click.option("--rate-hz", required=True, type=FiniteFloat(0, low_open=True), help="Sample rate of the recording.")
@units_option
@click.option("--turn-deg", type=FiniteFloat(), default=None,
              help="Signed angle of every turn (right-hand rule about its axis); default: the sense from the data.")
@click.option("--tilt-sd-deg", type=FiniteFloat(0, low_open=True), default=2.0, show_default=True,
              help="How far a hand-placed face may be from its nominal attitude (1 sd).")
@click.option("--turn-sd-deg", type=FiniteFloat(0, low_open=True), default=2.0, show_default=True,
              help="How far a hand-made turn may be from its nominal angle (1 sd).")
@_gravity_option
@_out_option
def import_ferraris(csv_file, sections, annotated, rate_hz, units, turn_deg, tilt_sd_deg, turn_sd_deg, gravity, out,
                    force):
    """imucal's Ferraris session: six faces and a turn about each axis."""
    from rig.io.import_ferraris import import_ferraris as build

    def session():
        return build(rate_hz=rate_hz, units=sensor_units(units, ["accel", "gyro"]), csv=csv_file, sections=sections,
                     annotated=annotated, turn_deg=turn_deg, tilt_sd_deg=tilt_sd_deg, turn_sd_deg=turn_sd_deg,
                     gravity=gravity)
    _run(session, out, force)


@import_group.command("csv")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--time", "time_column", help="Column of the time stamps.")
@click.option("--time-unit", type=click.Choice(["s", "ms", "us"]), default="s", show_default=True)
@click.option("--rate-hz", type=FiniteFloat(0, low_open=True), help="Sample rate, for a file without time stamps.")
@click.option("--accel", help="Accelerometer columns x,y,z.")
@click.option("--gyro", help="Gyroscope columns x,y,z.")
@click.option("--mag", help="Magnetometer columns x,y,z.")
@click.option("--temp", "temp_column", help="Temperature column, degC.")
@units_option
@click.option("--delimiter", default=",", show_default=True)
@click.option("--header-line", type=click.IntRange(0), default=1, show_default=True,
              help="Line of the column names, for a logger that prints its settings above them; 0 for a file "
                   "without them, whose columns are then named by number from 1.")
@click.option("--field-uT", "field_uT", type=FiniteFloat(0, low_open=True),
              help="Local field magnitude, uT (with --mag); without it the magnetometer is calibrated to the "
                   "magnitude its own samples show.")
@initial_rest_option
@_gravity_option
@_out_option
def import_csv(file, time_column, time_unit, rate_hz, accel, gyro, mag, temp_column, units, delimiter, header_line,
               field_uT, initial_rest_s, gravity, out, force):
    """Any logger's CSV, given which columns hold what."""
    from rig.io.import_csv import import_csv as build

    sensors = {name: cols for name, cols in (("accel", _columns("--accel", accel)), ("gyro", _columns("--gyro", gyro)),
                                             ("mag", _columns("--mag", mag))) if cols}
    if not sensors:
        raise click.UsageError("name the columns of at least one sensor: --accel, --gyro or --mag")

    def session():
        return build(file, sensors, units=sensor_units(units, list(sensors)), time_column=time_column,
                     time_unit=time_unit, rate_hz=rate_hz, temp_column=temp_column, delimiter=delimiter,
                     gravity=gravity, field_uT=field_uT, header_line=header_line,
                     initial_rest_s=initial_rest_s)
    _run(session, out, force)
