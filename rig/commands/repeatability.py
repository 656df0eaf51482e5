"""`rig repeatability`: N sessions on the same unit and the spread of every element of B and H.

Every trial is a session like `rig calibrate`'s, and goes to the lab's store like one: `--store` or the
configuration's `[store] url`, mirrored while it runs (a `postgresql://` store) or recorded inside it (a folder
store, which `--out` must lie in). The series' report itself (`repeatability.md`) stays in `--out`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from rig.commands.common import mirrored, rig_config, run_session_to


@click.command()
@click.option("--sim", is_flag=True, help="Simulated rig: the same simulated unit, new noise every trial.")
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False))
@click.option("--trials", type=click.IntRange(2, 1000), required=True)
@click.option("--out", required=True, type=click.Path(file_okay=False, path_type=Path))
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True, help="The simulated unit.")
@click.option("--method", type=click.Choice(["joint", "two-step"]), default="joint", show_default=True)
@click.option("--orientations", type=click.IntRange(9, 64), default=None)
@click.option("--store", "store", default=None, metavar="URL|FOLDER",
              help="The lab's store every trial goes to ([store] url in the TOML): a postgresql:// URL (mirrored as "
                   "it runs) or a folder of session folders that --out must lie in.")
def repeatability(sim, config_path, trials, out, seed, method, orientations, store):
    """Run TRIALS sessions on one unit and report the mean and standard deviation of B and H (paper Fig. 7)."""
    from rig.exits import CommandError, Exit
    from rig.lab.errors import is_database_url
    from rig.report.repeatability import write_repeatability_report

    if not sim and not config_path:
        raise click.UsageError("give --sim or --config rig.toml")
    config = rig_config(config_path, orientations)
    store = store or config.store.get("url")
    if store is not None and not is_database_url(store) and not out.resolve().is_relative_to(Path(store).resolve()):
        raise CommandError(f"--store {store}: a folder store holds session folders, and --out {out} is not inside "
                           f"it (e.g. --out {Path(store) / out.name})", Exit.BAD_INPUT)
    runs, rejected = [], 0
    for k in range(trials):
        folder = out / f"trial-{k + 1:03d}"
        click.echo(f"trial {k + 1}/{trials} -> {folder}")
        with mirrored(folder, store):
            status = run_session_to(folder, config, sim=sim, seed=seed, time_scale=None, method=method,
                                    progress=False, trial=k)
        if status not in (Exit.OK, Exit.FAIL):          # a FAIL verdict is a result; anything else ends the series
            sys.exit(status)
        rejected += status == Exit.FAIL
        runs.append(calibration_triads(folder / "calibration.json"))
    truth = None
    if sim:
        import json
        truth = json.loads((out / "trial-001" / "truth.json").read_text())
    report = write_repeatability_report(out, runs, truth=truth)
    click.echo(f"wrote {report}")
    if rejected:
        click.echo(f"{rejected} of {trials} trials have the verdict FAIL", err=True)
        sys.exit(Exit.FAIL)


def calibration_triads(path: Path) -> dict:
    """The sensors of a calibration file as TriadCalibration objects."""
    import numpy as np

    from rig.calibration.numerics.result import TriadCalibration
    from rig.io.calibration_json import read_calibration

    out = {}
    for name, d in read_calibration(path)["sensors"].items():
        out[name] = TriadCalibration(np.array(d["B"], float), np.array(d["H"], float), d.get("method", ""),
                                     residual_rms=float(d.get("residual_rms", "nan")),
                                     B_std=np.array(d["B_std"]) if "B_std" in d else None,
                                     H_std=np.array(d["H_std"]) if "H_std" in d else None)
    return out
