"""The `rig` command line. Subcommands live beside what they drive and are imported when used."""

from __future__ import annotations

import importlib

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


@click.group(cls=LazyGroup)
@click.version_option(package_name="rig")
def main() -> None:
    """Acquisition and calibration rig for miniature inertial and magnetic sensor units."""


if __name__ == "__main__":
    main()
