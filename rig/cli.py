"""The `rig` command line. Subcommands live beside what they drive and are imported when used.

Every command ends with an exit code of the table in `rig.exits` (docs/reference/exit-codes.md), and none
prints a traceback: an unexpected exception is reported in one line, its traceback written to a file.
"""

from __future__ import annotations

import importlib
import sys

import click

from rig import exits

# The subcommands, imported only when run: name -> ("module:attribute" of a click command, its short help).
# The short help is what `rig --help` lists, kept here so that listing imports nothing;
# it is the first sentence of the command's docstring, as click shows it (tests/startup/test_help_table.py
# holds each equal to the command's own). One line per command; a bare "module:attribute" still works (the
# command is then imported to list it, and that test names the text to add).
SUBCOMMANDS: dict[str, tuple[str, str] | str] = {
    "calibrate": ("rig.commands.calibrate:calibrate",
                  "Run a calibration session and compute B and H of every sensor (or calibrate recorded data)."),
    "resume": ("rig.commands.calibrate:resume",
               "Finish an interrupted session: hold again at its last recorded orientation, record the rest, "
               "calibrate."),
    "plan": ("rig.commands.plan:plan", "Dry run: the schedule, its observability, its predicted accuracy and the ETA."),
    "export": ("rig.commands.export:export",
               "Write the session in SESSION as meta.json + samples.csv in the folder given by --to."),
    "repeatability": ("rig.commands.repeatability:repeatability",
                      "Run TRIALS sessions on one unit and report the mean and standard deviation of B and H "
                      "(paper Fig."),
    "paper": ("rig.commands.paper:paper", "Reproduce Table I (accelerometer) and Table II (gyroscope) of Zhang et al."),
    "discrepancy": ("rig.commands.discrepancy:discrepancy",
                    "Fit the linear model, test every candidate effect, report the ones the data support."),
    "noise": ("rig.commands.noise:noise",
              "The Allan deviation of a static recording and its noise terms, per sensor and axis."),
    "attitude": ("rig.commands.attitude:attitude",
                 "Run the quaternion UKF on a session with motion (the rig's folder or an interchange one) and "
                 "compare with its reference."),
    "validate": ("rig.commands.attitude:validate",
                 "Calibrate, run the dynamic trajectory on the same unit, and write the Table III attitude report."),
    "table": ("rig.turntable.cli:table", "Drive the two-axis Modbus turntable."),
    "sim-turntable": ("fixtures.turntable.cli:sim_turntable",
                      "Serve a fake two-axis turntable (map tt-map/1 or --profile) until Ctrl-C."),
    "chamber": ("rig.commands.chamber:chamber", "Drive the thermal chamber's temperature controller over Modbus."),
    "sim-chamber": ("fixtures.chamber.cli:sim_chamber",
                    "Serve a fake thermal chamber (profile watlow-f4t/loop1 or --profile) until Ctrl-C."),
    "import": ("rig.commands.importing:import_group",
               "A recording from another logger as a session folder every command accepts."),
    "push": ("rig.commands.lab:push",
            "Push session folders to the central store: what it lacks, once (pushing again adds nothing)."),
    "units": ("rig.commands.lab:units",
             "Every unit in the store: how many calibrations, the latest."),
    "history": ("rig.commands.lab:history",
               "Every calibration of a unit, oldest first, with drift flagged against the uncertainty."),
    "compare-rigs": ("rig.commands.lab:compare_rigs",
                    "The same (golden) unit on every rig: rig-to-rig differences with their uncertainty, "
                    "rigs that stand out, rigs that disagree with themselves."),
    "pass-fail": ("rig.commands.lab:pass_fail",
                 "Sessions by day and rig: complete (PASS), rejected (FAIL), failed, aborted, running."),
    "serve": ("rig.commands.lab_web:serve",
             "Serve the lab's web page: sessions with live progress, reports, unit histories, rig comparison."),
    "lab": ("rig.commands.lab_admin:lab",
            "Set up the lab's store and page: roles and their SQL, tables, users of the page."),
    "batch": ("rig.commands.lab_batch:batch",
             "Re-run calibration or the discrepancy analysis over stored sessions; results go back to the store."),
}


def subcommand_target(name: str) -> str:
    """The "module:attribute" of subcommand `name` (either shape of its SUBCOMMANDS entry)."""
    entry = SUBCOMMANDS[name]
    return entry if isinstance(entry, str) else entry[0]


def shortened(text: str, limit: int) -> str:
    """`text` cut to `limit` characters at a word, as click shortens a command's short help."""
    text = " ".join(text.split())
    if len(text) <= limit:
        return text
    if limit < len("..."):
        return "..."
    import textwrap

    return textwrap.shorten(text, limit, placeholder="...", break_on_hyphens=False)


class LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(SUBCOMMANDS))

    def get_command(self, ctx, name):
        cmd = super().get_command(ctx, name)
        if cmd is None and name in SUBCOMMANDS:
            module, attr = subcommand_target(name).split(":")
            cmd = getattr(importlib.import_module(module), attr)
        return cmd

    def format_commands(self, ctx, formatter):
        """click's list of commands, with the short help of SUBCOMMANDS so that listing imports none of them."""
        rows = []
        for name in self.list_commands(ctx):
            entry = SUBCOMMANDS.get(name) if name not in self.commands else None
            if isinstance(entry, tuple):
                rows.append((name, entry[1]))
                continue
            cmd = self.get_command(ctx, name)
            if cmd is not None and not cmd.hidden:
                rows.append((name, cmd))
        if rows:
            limit = formatter.width - 6 - max(len(name) for name, _ in rows)
            rows = [(name, shortened(help, limit) if isinstance(help, str) else help.get_short_help_str(limit))
                    for name, help in rows]
            with formatter.section("Commands"):
                formatter.write_dl(rows)

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        """click's main with the last-resort guard around it (see `guarded`)."""
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        if args is None:                     # the `rig` process itself (a test runner passes its arguments)
            exits.process_ends_with_command = True
            exits.stop_signals_raise_until_exit()
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
