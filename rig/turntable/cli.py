"""`rig table ...`: operate the turntable by hand (status, moves, homing, e-stop) over any link URL.

Commands that drive or power the table (move, home, enable, disable, reset) take the table's lock
(`rig.locks.table_lock`), so they are refused while a session or another operator's command runs on it;
`stop` and `estop` never wait for a lock (stopping must always be possible) and `status` only reads.
"""

from __future__ import annotations

import contextlib

import click

from rig.exits import CommandError, Exit, FiniteFloat, code_for, plain
from rig.errors import RigError
from rig.locks import table_lock
from rig.turntable.client import TurntableLink
from rig.turntable.errors import EStopActive, MoveRejected


class NumbersAsArguments(click.Command):
    """A command whose arguments may be negative numbers: `rig table move 45 -30`, not only `-- 45 -30`.

    click reads `-30` as an option; here, when a negative number is among the words (and no `--` was given),
    the options and their values are put first and a `--` before the rest.
    """

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if "--" not in args and any(_is_negative_number(a) for a in args):
            options, positional, k = [], [], 0
            while k < len(args):
                word = args[k]
                if word.startswith("-") and not _is_negative_number(word):
                    options.append(word)
                    if self._takes_value(word) and k + 1 < len(args):
                        options.append(args[k + 1])
                        k += 1
                else:
                    positional.append(word)
                k += 1
            args = options + ["--"] + positional
        return super().parse_args(ctx, args)

    def _takes_value(self, word: str) -> bool:
        if "=" in word:
            return False
        for param in self.params:
            if isinstance(param, click.Option) and word in param.opts + param.secondary_opts:
                return not param.is_flag and not param.count
        return False


def _is_negative_number(text: str) -> bool:
    if not text.startswith("-") or text.startswith("--"):
        return False
    try:
        float(text)
    except ValueError:
        return False
    return True


def _link(ctx: click.Context) -> TurntableLink:
    opts = ctx.obj
    return TurntableLink(opts["url"], profile=opts["profile"], timeout=opts["timeout"])


def _run(ctx: click.Context, action, motion: bool = False, locked: bool = True) -> None:
    """Connect, act, report; a turntable error becomes a non-zero exit with its message (docs/reference/exit-codes.md).

    A failed motion command also makes the table safe (stop, disable); a successful one leaves the
    servos on so the axes hold the position the operator asked for.
    """
    url = ctx.obj["url"]
    try:
        with table_lock(url) if locked else contextlib.nullcontext():
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
    except EStopActive as exc:
        message = plain(str(exc)).replace("; call reset()", "").replace("call reset()", "")
        raise CommandError(f"{message}; clear it with: rig table --url {url} reset", Exit.FAILED) from None
    except MoveRejected as exc:
        if exc.reason in OPERATOR_VALUE_ERRORS:           # the angles or rates asked for: the operator's to mend
            raise CommandError(f"{plain(str(exc))}: the table refuses the value given (its limits are in its "
                               "profile); the table was stopped and disabled", Exit.BAD_INPUT) from None
        raise CommandError(plain(str(exc)), code_for(exc)) from None
    except ProfileOrURLError as exc:
        raise CommandError(plain(str(exc)), Exit.BAD_INPUT) from None
    except RigError as exc:
        raise CommandError(plain(str(exc)), code_for(exc)) from None
    except (OSError, ValueError) as exc:
        raise CommandError(f"{url}: {plain(str(exc))}", Exit.FAILED) from None


OPERATOR_VALUE_ERRORS = ("OUT_OF_LIMITS", "BAD_VALUE")      # LAST_ERROR names of a refused value
ProfileOrURLError = ValueError      # a malformed profile or URL (ProfileError and the URL parser's errors)


@click.group()
@click.option("--url", required=True, envvar="RIG_TABLE_URL",
              help="tcp://HOST:PORT, rtu:///dev/ttyUSB0?baud=115200&parity=N, or rtu+socket://HOST:PORT")
@click.option("--profile", type=click.Path(dir_okay=False), default=None,
              help="register-map profile (TOML); default: the packaged tt-map/1")
@click.option("--timeout", type=FiniteFloat(0, 600, low_open=True), default=1.0, show_default=True,
              help="per-request timeout, s")
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
    _run(ctx, show, locked=False)


@table.command(cls=NumbersAsArguments)
@click.argument("outer", type=FiniteFloat())
@click.argument("inner", type=FiniteFloat())
@click.option("--speed", type=FiniteFloat(0, low_open=True), default=30.0, show_default=True, help="deg/s")
@click.option("--accel", type=FiniteFloat(0, low_open=True), default=60.0, show_default=True, help="deg/s^2")
@click.option("--tolerance", type=FiniteFloat(0, low_open=True), default=0.01, show_default=True, help="deg")
@click.pass_context
def move(ctx: click.Context, outer: float, inner: float, speed: float, accel: float, tolerance: float) -> None:
    """Enable and move both axes to OUTER INNER degrees (negative angles as they are: 45 -30); servos stay on."""
    def go(link: TurntableLink) -> None:
        link.enable()
        final = link.move_to(outer, inner, speed_dps=speed, accel_dps2=accel, tolerance_deg=tolerance)
        click.echo("in position: " + ", ".join(f"{s.name} {s.position_deg:+.4f} deg" for s in final))
    _run(ctx, go, motion=True)


@table.command()
@click.option("--timeout", "home_timeout", type=FiniteFloat(0, 3600, low_open=True), default=120.0,
              show_default=True, help="s")
@click.pass_context
def home(ctx: click.Context, home_timeout: float) -> None:
    """Enable and home both axes; servos stay on."""
    def go(link: TurntableLink) -> None:
        link.enable()
        link.home(timeout=home_timeout)
        click.echo("homed: " + ", ".join(f"{n} {p:+.4f} deg" for n, p in zip(link.profile.axis_names,
                                                                             link.positions())))
    _run(ctx, go, motion=True)


def _simple(name: str, doc: str, method: str, message: str, locked: bool = True):
    @table.command(name=name, help=doc)
    @click.pass_context
    def cmd(ctx: click.Context) -> None:
        def go(link: TurntableLink) -> None:
            getattr(link, method)()
            click.echo(message)
        _run(ctx, go, locked=locked)
    return cmd


_simple("stop", "Decelerate both axes to a stop (never waits for the table's lock).", "stop", "stopped",
        locked=False)
_simple("enable", "Servo on, both axes.", "enable", "enabled")
_simple("disable", "Servo off, both axes.", "disable", "disabled")
_simple("estop", "Software e-stop (latching) of both axes (never waits for the table's lock).", "estop",
        "e-stop latched", locked=False)
_simple("reset", "Reset the e-stop latch and alarms.", "reset", "reset: e-stop and alarms clear")
