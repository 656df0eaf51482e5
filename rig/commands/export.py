"""`rig export SESSION --to DIR`: a recorded session in the interchange layout (`imu-session-csv/1`)."""

from __future__ import annotations

from pathlib import Path

import click


@click.command()
@click.argument("session", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--to", "to", required=True, type=click.Path(file_okay=False, path_type=Path))
def export(session, to):
    """Write the session in SESSION as meta.json + samples.csv in the folder given by --to."""
    from rig.io.session_csv import write_session
    from rig.store import SessionStore

    store = SessionStore.open(session)
    meta = store.metadata
    data = store.to_session_data()
    extra = {k: meta[k] for k in ("unit", "operator", "start_utc", "end_utc", "status", "software", "truth")
             if k in meta}
    config = meta.get("config") or {}
    geometry = config.get("geometry") or {}
    if data.sample_rate_hz is None and (config.get("schedule") or {}).get("rate_hz"):
        data.sample_rate_hz = float(config["schedule"]["rate_hz"])
    table = {k: geometry[k] for k in ("outer_axis_world", "inner_axis_fixture") if k in geometry}
    write_session(data, to, extra_meta={"table": table, "rig_session": extra} if table else {"rig_session": extra})
    click.echo(f"wrote {to / 'meta.json'} and {to / 'samples.csv'} ({data.t.size} rows)")
