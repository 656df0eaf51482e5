"""`rig discrepancy SESSION_DIR --json OUT.json [--report DIR]`: what the linear model misses in a
measured (interchange) session, named in the `effects.md` vocabulary."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click


@click.command()
@click.argument("session_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--json", "json_out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Where to write the rig-discrepancy/1 report.")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder for the residual-vs-covariate plots (before / after each finding) and a summary.")
@click.option("--no-replay", is_flag=True, help="Skip replaying the schedule in the simulator.")
def discrepancy(session_dir, json_out, report_dir, no_replay):
    """Fit the linear model, test every candidate effect, report the ones the data support."""
    from rig.discrepancy import analyze
    from rig.errors import RigError
    from rig.io.atomic import write_text_atomic
    from rig.io.session_csv import read_session

    try:
        session = read_session(session_dir)
    except RigError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(2)
    session.meta.setdefault("session", session_dir.name)
    report = analyze(session, with_replay=not no_replay, plots_dir=report_dir)
    json_out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(json_out, json.dumps(report, indent=2, default=_plain) + "\n")
    if not report["findings"]:
        click.echo("no missing effect found: the linear model explains the data to within noise")
    for f in report["findings"]:
        amb = f" (ambiguous with {', '.join(f['ambiguous_with'])})" if f.get("ambiguous_with") else ""
        click.echo(f"{f['effect']} on {f['sensor']}: {f['magnitude']:.4g} +- {f['uncertainty']:.2g} {f['unit']}; "
                   f"held-out RMS {f['heldout_rms_before']:.3g} -> {f['heldout_rms_after']:.3g} {f['heldout_unit']}{amb}")
    click.echo(f"wrote {json_out}")


def _plain(x):
    import numpy as np

    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")
