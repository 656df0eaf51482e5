"""`rig table ...`: operate the turntable by hand (status, moves, homing, e-stop) over any link URL."""

from __future__ import annotations

import click

from rig.turntable.client import TurntableLink
from rig.turntable.errors import TurntableError


def _link(ctx: click.Context) -> TurntableLink:
    opts = ctx.obj
    return TurntableLink(opts["url"], profile=opts["profile"], timeout=opts["timeout"])


def _run(ctx: click.Context, action, motion: bool = False) -> None:
    """Connect, act, report; a turntable error becomes a non-zero exit with its message.

    A failed motion command also makes the table safe (stop, disable); a successful one leaves the
    servos on so the axes hold the position the operator asked for.
    """
    try:
        link = _link(ctx)
        link.connect()
        try:
            action(link)
        except BaseException:
            if motion:
                link.make_safe()
            raise
        finally:
            link.close()
    except (TurntableError, ValueError) as exc:
        raise click.ClickException(str(exc)) from exc


@click.group()
@click.option("--url", required=True, envvar="RIG_TABLE_URL",
              help="tcp://HOST:PORT, rtu:///dev/ttyUSB0?baud=115200&parity=N, or rtu+socket://HOST:PORT")
@click.option("--profile", type=click.Path(dir_okay=False), default=None,
              help="register-map profile (TOML); default: the packaged tt-map/1")
@click.option("--timeout", type=float, default=1.0, show_default=True, help="per-request timeout, s")
@click.pass_context
def table(ctx: click.Context, url: str, profile: str | None, timeout: float) -> None:
    """Drive the two-axis Modbus turntable."""
    ctx.obj = {"url": url, "profile": profile, "timeout": timeout}


@table.command()
@click.pass_context
def status(ctx: click.Context) -> None:
    """Print the controller and both axes."""
    def show(link: TurntableLink) -> None:
        device_id, version = link.identify()
        click.echo(f"{link.url}: DEVICE_ID=0x{device_id:04X} MAP_VERSION=0x{version:04X} ({link.profile.name})")
        click.echo(link.status().describe())
    _run(ctx, show)


@table.command()
@click.argument("outer", type=float)
@click.argument("inner", type=float)
@click.option("--speed", type=float, default=30.0, show_default=True, help="deg/s")
@click.option("--accel", type=float, default=60.0, show_default=True, help="deg/s^2")
@click.option("--tolerance", type=float, default=0.01, show_default=True, help="deg")
@click.pass_context
def move(ctx: click.Context, outer: float, inner: float, speed: float, accel: float, tolerance: float) -> None:
    """Enable and move both axes to OUTER INNER degrees (negative angles after --); servos stay on."""
    def go(link: TurntableLink) -> None:
        link.enable()
        final = link.move_to(outer, inner, speed_dps=speed, accel_dps2=accel, tolerance_deg=tolerance)
        click.echo("in position: " + ", ".join(f"{s.name} {s.position_deg:+.4f} deg" for s in final))
    _run(ctx, go, motion=True)


@table.command()
@click.option("--timeout", "home_timeout", type=float, default=120.0, show_default=True, help="s")
@click.pass_context
def home(ctx: click.Context, home_timeout: float) -> None:
    """Enable and home both axes; servos stay on."""
    def go(link: TurntableLink) -> None:
        link.enable()
        link.home(timeout=home_timeout)
        click.echo("homed: " + ", ".join(f"{n} {p:+.4f} deg" for n, p in zip(link.profile.axis_names,
                                                                             link.positions())))
    _run(ctx, go, motion=True)


def _simple(name: str, doc: str, method: str, message: str):
    @table.command(name=name, help=doc)
    @click.pass_context
    def cmd(ctx: click.Context) -> None:
        def go(link: TurntableLink) -> None:
            getattr(link, method)()
            click.echo(message)
        _run(ctx, go)
    return cmd


_simple("stop", "Decelerate both axes to a stop.", "stop", "stopped")
_simple("enable", "Servo on, both axes.", "enable", "enabled")
_simple("disable", "Servo off, both axes.", "disable", "disabled")
_simple("estop", "Software e-stop (latching) of both axes.", "estop", "e-stop latched")
_simple("reset", "Reset the e-stop latch and alarms.", "reset", "reset: e-stop and alarms clear")
