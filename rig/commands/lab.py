"""The lab's commands: `rig push`, `rig units`, `rig history`, `rig compare-rigs`, `rig pass-fail`.

`--store` is a `postgresql://` URL or a folder of session folders (also read from $RIG_STORE). Every error
of the store is one line naming it, with the exit code of `rig.exits`: 2 for what the user gave (an unknown
unit, a session that conflicts with the stored one), 3 for a database that cannot be used, 4 for a unit
another rig is calibrating at the same time.
"""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path

import click

from rig.exits import CommandError, Exit, FiniteFloat, code_for, command_error

LAB_MODULES = ("psycopg", "psycopg_pool", "starlette", "uvicorn", "jinja2", "plotly", "dask", "distributed")
STORE_HELP = "postgresql://USER@HOST:PORT/DB, or a folder of rig session folders ($RIG_STORE)."


def store_option(f):
    return click.option("--store", "store_url", required=True, envvar="RIG_STORE", help=STORE_HELP)(f)


def source_option(f):
    return click.option("--source", "source", default="rig", show_default=True,
                        help="Which calibration of each session: rig (the rig's own), batch (the latest batch "
                             "re-calibration) or batch:RUN (one batch run's).")(f)


def json_option(f):
    return click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path), default=None,
                        help="Also write the answer as JSON to this file.")(f)


@contextlib.contextmanager
def lab_errors():
    """The store's and the rig's errors as one clear line and their exit code; never a traceback."""
    from rig.errors import RigError

    try:
        yield
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] not in LAB_MODULES:
            raise
        raise CommandError(f"the lab's commands need the package {exc.name!r}: pip install 'rig[lab]'",
                           Exit.FAILED) from None
    except (RigError, OSError) as exc:
        raise command_error(exc) from None


def opened(store_url: str, **kw):
    from rig.lab.stores import open_store

    return open_store(store_url, **kw)


def say_skipped(store, data: dict | None = None) -> None:
    """Name every folder or record the store left out of the answer, on stderr (and in the JSON)."""
    skipped = dict(getattr(store, "skipped", {}) or {})
    for reason in skipped.values():
        click.echo(f"warning: skipped {reason}", err=True)
    if data is not None and skipped:
        data["skipped"] = [{"what": what, "reason": reason} for what, reason in skipped.items()]


def write_json(path: Path | None, data: dict) -> None:
    if path is None:
        return
    from rig.io.atomic import write_text_atomic

    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(data, indent=2, default=str) + "\n")


# -- push ------------------------------------------------------------------------------------------
@click.command()
@click.argument("session_dir", required=False, type=click.Path(file_okay=False, path_type=Path))
@click.option("--all", "root", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Push every session folder under ROOT.")
@store_option
@click.option("--rig", "rig_name", default=None, help="The rig's name in the store (default: the session's "
              "metadata `rig`, else the host that recorded it).")
@click.option("--follow", is_flag=True, help="Keep pushing while the session runs, until it ends (a live mirror).")
@click.option("--wait-s", "wait_s", type=FiniteFloat(0.0), default=600.0, show_default=True,
              help="With --follow: after the session ends, how long a store that is away is waited for (tried "
                   "with a back-off of 1 to 30 s).")
def push(session_dir, root, store_url, rig_name, follow, wait_s):
    """Push session folders to the central store: what it lacks, once (pushing again adds nothing)."""
    from rig.lab.errors import is_database_url

    if (session_dir is None) == (root is None):
        raise click.UsageError("give one session folder, or --all ROOT")
    if follow and root is not None:
        raise click.UsageError("--follow follows one session folder, not --all")
    if not is_database_url(store_url):
        raise CommandError(f"{store_url}: push goes to a postgresql:// store; a folder store reads session folders "
                           "where they lie (copy the folder into it instead)", Exit.BAD_INPUT)
    if follow:
        with lab_errors():
            sys.exit(_follow(session_dir, store_url, rig_name, wait_s))
    with lab_errors():
        from procedures.slot_session import slot_folders
        from rig.lab.local import session_folders

        folders = session_folders(root) if session_dir is None else slot_folders(session_dir) or [session_dir]
        if not folders:
            click.echo(f"{root}: no session folders found")
            return
        sys.exit(_push_all(folders, store_url, rig_name))


def _push_all(folders: list[Path], store_url: str, rig_name: str | None) -> int:
    from rig.errors import RigError
    from rig.lab.errors import StoreDenied, StoreError
    from rig.lab.mirror import push_folder
    from rig.lab.pg import connect

    try:
        conn = connect(store_url)
    except StoreError as exc:
        raise CommandError(f"{exc}; nothing was pushed: the session folders are unchanged and can be "
                           "pushed later", code_for(exc)) from None
    code, pushed = Exit.OK, 0
    try:
        for folder in folders:
            try:
                result = push_folder(folder, store_url, rig=rig_name, conn=conn)
            except StoreDenied as exc:         # this folder only: the role may not push it
                click.echo(f"Error: {exc}", err=True)
                code = code if code != Exit.OK else code_for(exc)
                continue
            except StoreError as exc:          # the database itself: nothing more can be pushed now
                raise CommandError(f"{exc}; the session folders are unchanged: push again when the store is "
                                   "back (what was pushed is kept, nothing is pushed twice)", code_for(exc)) from None
            except RigError as exc:            # this folder only (refused, unreadable): say why, go on
                click.echo(f"Error: {exc}", err=True)
                code = code if code != Exit.OK else code_for(exc)
                continue
            pushed += result.holds
            click.echo(result.line())
    finally:
        conn.close()
    if len(folders) > 1:
        click.echo(f"{len(folders)} session folders, {pushed} new holds pushed")
    return code


def _follow(session_dir: Path, store_url: str, rig_name: str | None, wait_s: float) -> int:
    import signal
    import threading

    from rig.lab.mirror import SessionMirror
    from rig.lab.pg import check_url

    check_url(store_url)
    mirror = SessionMirror(session_dir, store_url, rig=rig_name, wait_down_s=wait_s)
    stop = threading.Event()

    def stop_now(*_) -> None:                # a last push if the store is there; no more waiting for it
        mirror.wait_down_s = 0.0
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, stop_now)
    click.echo(f"following {session_dir} into the store (Ctrl-C stops after a last push)", err=True)
    outcome = mirror.run(stop)
    if outcome.complete:
        return Exit.OK
    return outcome.code or Exit.FAILED


# -- questions -------------------------------------------------------------------------------------
@click.command()
@store_option
@json_option
def units(store_url, json_out):
    """Every unit in the store: how many calibrations, the latest."""
    from rig.lab.records import iso

    with lab_errors():
        store = opened(store_url)
        try:
            found = store.units()
        finally:
            store.close()
    data = {"units": [{"serial": u["serial"], "calibrations": u["calibrations"], "last_utc": iso(u["last_utc"]),
                       "sessions": u["sessions"], "board": u["board"]} for u in found]}
    say_skipped(store, data)
    if not found:
        click.echo("no units in the store yet")
    for u in data["units"]:
        click.echo(f"{u['serial']:<24} {u['calibrations']:>4} calibrations  {u['sessions']:>4} sessions  "
                   f"last {u['last_utc'] or '-'}")
    with lab_errors():
        write_json(json_out, data)


@click.command()
@click.argument("serial")
@store_option
@json_option
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Plot B and H over time with their uncertainties (PNG, SVG or PDF).")
@source_option
def history(serial, store_url, json_out, plot, source):
    """Every calibration of a unit, oldest first, with drift flagged against the uncertainty."""
    from rig.lab.questions import history as unit_history
    from rig.lab.records import check_source, shared_table_line

    with lab_errors():
        source = check_source(source)
        store = opened(store_url)
        try:
            known = {u["serial"] for u in store.units()}
            if serial not in known:
                raise CommandError(f"unit {serial!r} is not in {store.describe()} ({len(known)} units are; "
                                   "`rig units` lists them)", Exit.BAD_INPUT)
            data = unit_history(store, serial, source)
        finally:
            store.close()
    say_skipped(store, data)
    if not data["calibrations"]:
        click.echo(f"unit {serial}: no calibration stored yet")
    for entry in data["calibrations"]:
        flags = [s for s, d in entry.get("drift", {}).items() if d["flagged"]]
        click.echo(f"{entry['started_utc']}  {entry['session']:<28} rig {entry['rig']:<12} {entry['status']:<9} "
                   f"{entry['verdict'] or '-':<11}"
                   + (f"  DRIFT: {', '.join(flags)} (> {data['z_flag']:g} sigma since the one before)" if flags else ""))
        shared = shared_table_line(entry.get("table"))
        if shared:
            click.echo(f"{'':26}{shared} (slots session {entry['table'].get('session')})")
        for other in entry["beside"]:
            moved = [s for s, d in other["change"].items() if d["flagged"]]
            click.echo(f"{'':26}beside it: {other['source']} ({other['verdict'] or 'no verdict'})"
                       + (f", differs in {', '.join(moved)} (> {data['z_flag']:g} sigma)" if moved else ""))
    with lab_errors():
        write_json(json_out, data)
        if plot is not None and data["calibrations"]:
            from rig.lab.plots import history_figure

            history_figure(data, plot)
            click.echo(f"wrote {plot}")


@click.command("compare-rigs")
@click.option("--unit", "unit", required=True, help="The golden unit's serial.")
@store_option
@json_option
@source_option
def compare_rigs(unit, store_url, json_out, source):
    """The same (golden) unit on every rig: rig-to-rig differences with their uncertainty, rigs that stand out,
    rigs that disagree with themselves."""
    from rig.lab.questions import compare_rigs as compare
    from rig.lab.records import check_source

    with lab_errors():
        source = check_source(source)
        store = opened(store_url)
        try:
            data = compare(store, unit, source)
        finally:
            store.close()
    say_skipped(store, data)
    if not data["rigs"]:
        raise CommandError(f"unit {unit!r} has no calibration ({source}) in {store.describe()}", Exit.BAD_INPUT)
    for rig in data["rigs"]:
        ratios = [q["ratio"] for quantities in rig["scatter"].values() for q in quantities.values()]
        click.echo(f"rig {rig['rig']}: {rig['sessions']} calibrations of {unit}"
                   + (f"; its sessions scatter up to {max(ratios):.3g} times their stated uncertainty" if ratios
                      else ""))
    if len(data["rigs"]) < 2:
        click.echo("only one rig has calibrated this unit: nothing to compare")
    for diff in data["differences"]:
        pair = " - ".join(diff["rigs"])
        for sensor, d in diff["sensors"].items():
            click.echo(f"  {pair:<24} {sensor:<5} B z={_z(d['B_z'])}  H z={_z(d['H_z'])}  rotation "
                       f"{_vec(d['rotation_deg'])} deg (z={_z(d['rotation_z'])})")
    for finding in data["findings"]:
        click.echo(finding["text"])
    if len(data["rigs"]) >= 2 and not data["findings"]:
        click.echo(f"the rigs agree within {data['z_flag']:g} sigma")
    with lab_errors():
        write_json(json_out, data)


@click.command("pass-fail")
@store_option
@click.option("--where", "where", multiple=True, help="key=value (unit, rig, operator, status, since, until).")
@json_option
def pass_fail(store_url, where, json_out):
    """Sessions by day and rig: complete (PASS), rejected (FAIL), failed, aborted, running."""
    from rig.lab.questions import pass_fail as table
    from rig.lab.records import Filters

    with lab_errors():
        filters = Filters.from_where(where)
        store = opened(store_url)
        try:
            data = table(store, filters)
        finally:
            store.close()
    say_skipped(store, data)
    click.echo(f"{'day':<11} {'rig':<14} {'complete':>8} {'rejected':>8} {'failed':>6} {'aborted':>7} "
               f"{'running':>7}  passed")
    for r in data["rows"]:
        share = "-" if r["passed"] is None else f"{100 * r['passed']:.0f} %"
        click.echo(f"{r['day']:<11} {r['rig']:<14} {r['complete']:>8} {r['rejected']:>8} {r['failed']:>6} "
                   f"{r['aborted']:>7} {r['running']:>7}  {share}")
    with lab_errors():
        write_json(json_out, data)


def _z(z) -> str:
    return "-" if z is None else f"{z:.3g}"


def _vec(v) -> str:
    return "[" + ", ".join(f"{x:+.4f}" for x in v) + "]"
