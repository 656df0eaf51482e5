"""`rig --help` lists the subcommands from the SUBCOMMANDS table without importing them.

The table's short help must be what click would show from each command itself, at any terminal width, or the
listing drifts from the commands; and listing must import none of the heavy packages a command may need.
"""

from __future__ import annotations

import importlib
import subprocess
import sys

import click
from click.testing import CliRunner
import pytest

from rig.cli import SUBCOMMANDS, main, shortened, subcommand_target

LIMITS = [3, 10, 25, 40, 45, 53, 60, 74, 90, 120, 400]


def _command(name: str) -> click.Command:
    module, attr = subcommand_target(name).split(":")
    return getattr(importlib.import_module(module), attr)


@pytest.mark.parametrize("name", sorted(SUBCOMMANDS))
def test_table_short_help_equals_the_commands_own(name):
    entry = SUBCOMMANDS[name]
    cmd = _command(name)
    own = cmd.get_short_help_str(10 ** 6)
    assert isinstance(entry, tuple), \
        f'SUBCOMMANDS[{name!r}]: write ("{entry}", {own!r}) so that --help need not import it'
    assert not cmd.hidden, f"{name} is hidden but listed by --help from SUBCOMMANDS"
    for limit in LIMITS:
        assert shortened(entry[1], limit) == cmd.get_short_help_str(limit), (name, limit)


def test_help_lists_every_subcommand_as_click_would(monkeypatch):
    """The listing equals click's own (each command imported and asked), at two terminal widths."""
    for width in (50, 100):
        monkeypatch.setenv("COLUMNS", str(width))
        ours = CliRunner().invoke(main, ["--help"], prog_name="rig", terminal_width=width)
        group = click.Group(name="rig", help=main.help, params=main.params,
                            commands={name: _command(name) for name in SUBCOMMANDS})
        theirs = CliRunner().invoke(group, ["--help"], prog_name="rig", terminal_width=width)
        assert ours.exit_code == 0 and theirs.exit_code == 0
        assert ours.output == theirs.output


def test_help_imports_no_command_numpy_or_scipy():
    probe = ("import sys, runpy\n"
             "sys.argv = ['rig', '--help']\n"
             "try:\n    runpy.run_module('rig.cli', run_name='__main__')\n"
             "except SystemExit as e:\n    assert e.code in (0, None), e.code\n"
             "print(' '.join(sorted(sys.modules)), file=sys.stderr)\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "calibrate" in done.stdout
    loaded = done.stderr.split()
    heavy = [m for m in loaded if m.split(".")[0] in {"numpy", "scipy", "filterpy", "fixtures", "procedures", "drivers",
                                                      "pymodbus", "matplotlib", "tqdm"}
             or m.startswith(("rig.commands", "rig.turntable", "rig.config"))]
    assert heavy == []
