"""The `rig` command line. Subcommands live beside what they drive and are imported when used.

Every command ends with an exit code of the table in `rig.exits` (README, "Exit codes"), and none
prints a traceback: an unexpected exception is reported in one line, its traceback written to a file.
"""

from __future__ import annotations

import importlib
import sys

import click

# name -> "module:attribute" of a click command
SUBCOMMANDS = {
    "calibrate": "rig.commands.calibrate:calibrate",
    "resume": "rig.commands.calibrate:resume",
    "plan": "rig.commands.calibrate:plan",
    "export": "rig.commands.export:export",
    "repeatability": "rig.commands.repeatability:repeatability",
    "paper": "rig.commands.paper:paper",
    "discrepancy": "rig.commands.discrepancy:discrepancy",
    "attitude": "rig.commands.attitude:attitude",
    "validate": "rig.commands.attitude:validate",
    "table": "rig.turntable.cli:table",
    "sim-turntable": "fixtures.turntable.cli:sim_turntable",
    "import": "rig.commands.importing:import_group",
    "push": "rig.commands.lab:push",
    "units": "rig.commands.lab:units",
    "history": "rig.commands.lab:history",
    "compare-rigs": "rig.commands.lab:compare_rigs",
    "pass-fail": "rig.commands.lab:pass_fail",
    "serve": "rig.commands.lab_web:serve",
    "batch": "rig.commands.lab_batch:batch",
}


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(SUBCOMMANDS))

    def get_command(self, ctx, name):
        cmd = super().get_command(ctx, name)
        if cmd is None and name in SUBCOMMANDS:
            module, attr = SUBCOMMANDS[name].split(":")
            cmd = getattr(importlib.import_module(module), attr)
        return cmd

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """click's main with the last-resort guard around it (see `guarded`)."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        sys.exit(guarded(lambda: super(LazyGroup, self).main(args, prog_name, complete_var,
                                                             standalone_mode=False, **extra), args))


def guarded(run, args=None) -> int:
    """Run the command line; the exit code of how it ended.

    click's own errors keep their codes, except that a bare `click.ClickException` (exit 1) is a failure (3),
    since 1 means a FAIL verdict. A stop signal that ends a command outside a session exits 128 + signal.
    Anything unexpected prints one line and where its traceback was written, and exits 70.
    """
    try:
        run()
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else (0 if e.code is None else _message(str(e.code)))
    except click.exceptions.Exit as e:
        return e.exit_code
    except click.Abort as e:
        signum = getattr(e.__cause__, "signum", 2)
        click.echo("aborted", err=True)
        return 128 + signum
    except click.ClickException as e:
        from rig.exits import CommandError, Exit, plain

        e.message = plain(e.message)
        e.show()
        if e.exit_code == 1 and not isinstance(e, CommandError):
            return Exit.FAILED
        return e.exit_code
    except BrokenPipeError:
        return 0
    except Exception as e:          # the last resort: a bug, never a traceback on the terminal
        return _crash(e, args)
    return 0


def _message(text: str) -> int:
    click.echo(text, err=True)
    return 1


def _crash(exc: BaseException, args) -> int:
    import tempfile
    import traceback

    from rig.exits import Exit, command_error

    from rig.errors import RigError

    if isinstance(exc, RigError):         # a known error a command forgot to catch: still one clear line
        err = command_error(exc)
        err.show()
        return err.exit_code
    if isinstance(exc, OSError) and exc.strerror:     # a file or folder the system refused
        where = f"{exc.filename}: " if exc.filename else ""
        click.echo(f"Error: {where}{exc.strerror}", err=True)
        user_path = isinstance(exc, (FileNotFoundError, NotADirectoryError, IsADirectoryError, PermissionError))
        return Exit.BAD_INPUT if user_path else Exit.FAILED
    command = " ".join(["rig", *(args if args is not None else sys.argv[1:])])
    where = "(the traceback could not be written)"
    try:
        with tempfile.NamedTemporaryFile("w", prefix="rig-error-", suffix=".log", delete=False) as f:
            f.write(f"{command}\n\n{''.join(traceback.format_exception(exc))}")
            where = f"the traceback is in {f.name}"
    except OSError:
        pass
    click.echo(f"Error: internal error in `{command}`: {type(exc).__name__}: {exc}; {where} "
               "(please report it)", err=True)
    return Exit.INTERNAL


@click.group(cls=LazyGroup)
@click.version_option(package_name="rig")
def main() -> None:
    """Acquisition and calibration rig for miniature inertial and magnetic sensor units."""


if __name__ == "__main__":
    main()
