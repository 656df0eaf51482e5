"""`rig batch calibrate|discrepancy --store URL --where key=value ...`: re-analyse an archive on Dask."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from rig.commands.lab import json_option, lab_errors, opened, say_skipped, store_option, write_json
from rig.exits import CommandError, Exit, stop_signals_raise


@click.command()
@click.argument("kind", type=click.Choice(["calibrate", "discrepancy"]))
@store_option
@click.option("--where", "where", multiple=True,
              help="key=value, repeatable (unit, rig, operator, status, since, until, session); all must hold.")
@click.option("--scheduler", default=None, help="Address of a running Dask scheduler (tcp://HOST:PORT); "
              "default: a local cluster on this machine.")
@click.option("--workers", type=click.IntRange(1, 256), default=None,
              help="Workers of the local cluster (default 2; ignored with --scheduler).")
@click.option("--method", type=click.Choice(["joint", "two-step"]), default="joint", show_default=True,
              help="Estimator for calibrate.")
@click.option("--replay", is_flag=True, help="discrepancy: also replay each schedule in the simulator (slower).")
@json_option
def batch(kind, store_url, where, scheduler, workers, method, replay, json_out):
    """Re-run calibration or the discrepancy analysis over stored sessions; results go back to the store.

    A re-calibration is stored beside the rig's own result, with its verdict by the rig's limits; the exit code
    is 1 when a verdict is FAIL."""
    from rig.lab.batch import run_batch
    from rig.lab.errors import is_database_url
    from rig.lab.records import Filters

    if scheduler and workers:
        raise click.UsageError("--workers sizes the local cluster; a --scheduler has its own workers")
    with lab_errors():
        filters = Filters.from_where(where)
        url = store_url if is_database_url(store_url) else str(Path(store_url).resolve())
        store = opened(url, write=True)
        try:
            keys = store.select_keys(filters)
            say_skipped(store)
            if not keys:
                if not where or not store.select_keys(Filters.from_where(())):
                    raise CommandError(_no_session(store), Exit.BAD_INPUT)
                click.echo(f"no session in {store.describe()} matches {' '.join(where)}")
                write_json(json_out, {"schema": "rig-batch/1", "kind": kind, "sessions": 0, "ok": 0, "failed": []})
                return
            try:
                with stop_signals_raise():      # the cluster closed on the way out, not left behind
                    summary = run_batch(store, url, kind, keys, scheduler=scheduler, workers=workers,
                                        options={"method": method, "replay": _replay() if replay else None},
                                        echo=click.echo)
            except OSError as exc:
                raise CommandError(f"Dask scheduler {scheduler or '(local cluster)'}: {exc}", Exit.FAILED) from None
        finally:
            store.close()
        write_json(json_out, summary)
    click.echo(f"{summary['ok']} of {summary['sessions']} sessions analysed in {summary['seconds']:.1f} s on "
               f"{summary['workers']} worker{'s' if summary['workers'] != 1 else ''}; results stored as run {summary['run']}")
    if summary["verdicts"]:
        click.echo("verdicts of the re-calibrations (by each session's own limits): "
                   + ", ".join(f"{n} {verdict}" for verdict, n in summary["verdicts"].items()))
    for f in summary["failed"][:20]:
        click.echo(f"  {f['session']}: {f['error']}", err=True)
    if summary["failed"]:
        click.echo(f"{len(summary['failed'])} sessions could not be analysed (their reasons are stored)", err=True)
        sys.exit(Exit.FAILED)
    if summary["verdict_fail"]:
        click.echo(f"{len(summary['verdict_fail'])} re-calibrations have the verdict FAIL (stored beside the rigs' "
                   "own)", err=True)
        sys.exit(Exit.FAIL)


def _no_session(store) -> str:
    """Why a store with no session at all is an input error: a wrong folder, or one of interchange recordings,
    which batch does not read (they have no rig session store)."""
    from rig.lab.local import interchange_folders

    found = interchange_folders(store.describe()) if store.kind == "folder" else []
    if not found:
        return f"{store.describe()}: no session recorded by rig in it; nothing was analysed"
    return (f"{store.describe()}: no session recorded by rig in it, but {len(found)} interchange "
            f"recording{'s' if len(found) != 1 else ''} (e.g. {found[0]}), which batch does not read; run "
            "`rig calibrate --from DIR` or `rig discrepancy DIR` on each; nothing was analysed")


def _replay():
    """The schedule replay runs the simulator (procedures), so the application hands it to the workers."""
    from procedures.replay import replay_comparison

    return replay_comparison
