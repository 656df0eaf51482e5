"""`rig chamber ...`: operate the thermal chamber by hand (status, set point and ramp, run, stop) over any link
URL, or against a fake chamber in this process (`--sim`).

Commands that change the chamber (set, run) take the chamber's lock (`rig.locks.chamber_lock`), so they are
refused while a session or another operator's command drives it; `stop` never waits for a lock (stopping
must always be possible) and `status` only reads. A command leaves the chamber as it set it (running at the
set point asked for); only `stop` and a failure on the way make it safe (set point to ambient, stopped).
"""

from __future__ import annotations

import contextlib

import click

from fixtures.chamber import ChamberServer, FakeChamber
from rig.chamber.client import ChamberLink
from rig.chamber.errors import SetPointNotReached
from rig.clock import SimClock
from rig.errors import RigError
from rig.exits import CommandError, Exit, FiniteFloat, code_for, plain
from rig.locks import chamber_lock


def _run(ctx: click.Context, action, locked: bool = True, safe_on_failure: bool = False) -> None:
    """Connect, act, report; a chamber error becomes its exit code and one line (docs/reference/exit-codes.md)."""
    opts = ctx.obj
    with contextlib.ExitStack() as stack:
        try:
            if opts["sim"]:
                clock = SimClock()
                server = stack.enter_context(ChamberServer(FakeChamber(clock, opts["profile"])))
                url, locked = server.url, False
            else:
                clock, url = None, opts["url"]
            if locked:
                stack.enter_context(chamber_lock(url))
            link = ChamberLink(url, profile=opts["profile"], clock=clock, timeout=opts["timeout"])
            link.connect()
            try:
                action(link)
            except BaseException:
                if safe_on_failure:
                    link.make_safe()
                raise
            finally:
                link.close()
        except SetPointNotReached as exc:
            raise CommandError(plain(str(exc)), Exit.FAILED) from None
        except ValueError as exc:               # a malformed profile or URL, a set point past the limits
            raise CommandError(plain(str(exc)), Exit.BAD_INPUT) from None
        except RigError as exc:
            raise CommandError(plain(str(exc)), code_for(exc)) from None
        except OSError as exc:
            raise CommandError(f"{opts['url'] or 'simulated chamber'}: {plain(str(exc))}", Exit.FAILED) from None


@click.group()
@click.option("--url", envvar="RIG_CHAMBER_URL", default=None,
              help="tcp://HOST:PORT, rtu:///dev/ttyUSB0?baud=9600&parity=N, or rtu+socket://HOST:PORT")
@click.option("--sim", is_flag=True, help="A fake chamber served in this process (simulated time) instead of --url.")
@click.option("--profile", type=click.Path(dir_okay=False), default=None,
              help="register profile (TOML); default: the packaged Watlow F4T one")
@click.option("--timeout", type=FiniteFloat(0, 600, low_open=True), default=1.0, show_default=True,
              help="per-request timeout, s")
@click.pass_context
def chamber(ctx: click.Context, url: str | None, sim: bool, profile: str | None, timeout: float) -> None:
    """Drive the thermal chamber's temperature controller over Modbus."""
    if sim == (url is not None):
        raise CommandError("give exactly one of --url (or RIG_CHAMBER_URL) and --sim", Exit.BAD_INPUT)
    ctx.obj = {"url": url, "sim": sim, "profile": profile, "timeout": timeout}


@chamber.command()
@click.pass_context
def status(ctx: click.Context) -> None:
    """Print the air temperature, set point, ramp, run state and alarms."""
    def show(link: ChamberLink) -> None:
        click.echo(f"{link.url} ({link.profile.name}): {link.status().describe()}")
    _run(ctx, show, locked=False)


@chamber.command(name="set")
@click.option("--c", "c", type=FiniteFloat(), required=True, help="set point, C")
@click.option("--ramp", type=FiniteFloat(0), default=None, help="ramp rate, C/min (0: step; default: unchanged)")
@click.option("--wait", is_flag=True, help="wait until the air is within --tolerance of the set point")
@click.option("--tolerance", type=FiniteFloat(0, low_open=True), default=0.5, show_default=True, help="C")
@click.option("--soak-timeout", type=FiniteFloat(0, low_open=True), default=3600.0, show_default=True,
              help="s, with --wait")
@click.pass_context
def set_(ctx: click.Context, c: float, ramp: float | None, wait: bool, tolerance: float, soak_timeout: float) -> None:
    """Write the set point (and ramp rate) and run the chamber; with --wait, until the air gets there."""
    def go(link: ChamberLink) -> None:
        if ramp is not None:
            link.ramp_rate(ramp)
        link.set_point(c)
        link.run()
        if wait:
            air = link.wait_air(c, tolerance, soak_timeout)
            click.echo(f"air {air:.2f} C: within {tolerance:g} C of {c:g} C")
        else:
            click.echo(f"running to {c:g} C" + ("" if ramp is None else f" at {ramp:g} C/min" if ramp else
                                                " (step)"))
    _run(ctx, go, safe_on_failure=True)


@chamber.command()
@click.pass_context
def run(ctx: click.Context) -> None:
    """Switch the chamber's conditioning on at its present set point."""
    def go(link: ChamberLink) -> None:
        link.run()
        click.echo("running")
    _run(ctx, go)


@chamber.command()
@click.pass_context
def stop(ctx: click.Context) -> None:
    """Leave the chamber safe: set point to ambient, conditioning off (never waits for the chamber's lock)."""
    def go(link: ChamberLink) -> None:
        link.stop()
        click.echo(f"stopped: set point {link.profile.ambient_c:g} C, conditioning off")
    _run(ctx, go, locked=False)
