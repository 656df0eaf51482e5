"""`rig paper`: the Monte Carlo of the paper's Tables I and II (Zhang et al. 2015), printed beside the paper's
published rows where those are known (they could not be retrieved here; the tables say so)."""

from __future__ import annotations

import json
from pathlib import Path

import click


@click.command()
@click.option("--runs", type=click.IntRange(1, 100000), default=1000, show_default=True)
@click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path), required=True)
@click.option("--plots", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder for the figures (PNG).")
@click.option("--gyro-runs", type=click.IntRange(1, 100000), default=50, show_default=True,
              help="Monte Carlo runs of Table II (each runs the UKF to 50 passes: about 0.3 s a run).")
@click.option("--seed", type=int, default=0, show_default=True)
def paper(runs, json_out, plots, gyro_runs, seed):
    """Reproduce Table I (accelerometer) and Table II (gyroscope) of Zhang et al. 2015."""
    from procedures.paper_table1 import plot_table1, run_table1
    from procedures.paper_table2 import plot_table2, run_table2

    t1 = run_table1(runs=runs, seed=seed)
    t2 = run_table2(runs=gyro_runs, seed=seed)
    for name, table in (("Table I (accelerometer)", t1), ("Table II (gyroscope)", t2)):
        click.echo(f"{name}: {table.get('runs')} runs")
        for line in format_rows(table):
            click.echo("  " + line)
        if not table.get("published"):
            click.echo(f"  paper's rows: {table.get('published_note') or 'not available'}")
    click.echo(f"Table I: share of runs with B error < 0.1 %: {t1.get('b_within_0p1pct')}")
    json_out.parent.mkdir(parents=True, exist_ok=True)
    json_out.write_text(json.dumps(_finite({"table1": t1, "table2": t2}), indent=2, allow_nan=False) + "\n")
    if plots:
        plots.mkdir(parents=True, exist_ok=True)
        plot_table1(t1, plots)
        plot_table2(t2, plots)
    click.echo(f"wrote {json_out}")


def _finite(obj):
    """JSON has no NaN: an undefined statistic (a standard deviation of one run) becomes null."""
    import math

    import numpy as np

    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _finite(obj.tolist())
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def format_rows(table: dict) -> list[str]:
    lines = []
    published = {r.get("iteration"): r for r in (table.get("published") or {}).get("rows", [])} \
        if isinstance(table.get("published"), dict) else {}
    for row in table.get("rows", []):
        it = row.get("iteration")
        fields = ", ".join(f"{k} {v:.3g}" for k, v in row.items()
                           if k != "iteration" and isinstance(v, (int, float)) and v == v)
        line = f"iteration {it:>2}: {fields}"
        if it in published:
            line += f" | paper: {published[it]}"
        lines.append(line)
    return lines
