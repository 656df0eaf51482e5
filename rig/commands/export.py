"""`rig export SESSION --to DIR`: a recorded session in the interchange layout (`imu-session-csv/1`)."""

from __future__ import annotations

from pathlib import Path

import click

from rig.exits import CommandError, Exit, command_error

EXPORTED = ("meta.json", "samples.csv")


@click.command()
@click.argument("session", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--to", "to", required=True, type=click.Path(file_okay=False, path_type=Path))
@click.option("--force", is_flag=True, help="Replace an interchange session already in the --to folder.")
def export(session, to, force):
    """Write the session in SESSION as meta.json + samples.csv in the folder given by --to."""
    from rig.commands.sessions import session_from_store
    from rig.errors import RigError
    from rig.io.session_writer import write_session
    from rig.store import SessionStore

    present = [name for name in EXPORTED if (to / name).exists()]
    if present and not force:
        raise CommandError(f"{to}: already holds {' and '.join(present)}; give --force to replace them, or "
                           "another --to", Exit.BAD_INPUT)
    try:
        with SessionStore.open(session) as store:
            meta = store.metadata
            data = session_from_store(store)
        extra = {k: meta[k] for k in ("unit", "operator", "start_utc", "end_utc", "status", "software", "truth",
                                      "verdict", "resumes") if k in meta}
        write_session(data, to, extra_meta={"rig_session": extra})
    except RigError as e:
        raise command_error(e) from None
    except OSError as e:
        raise CommandError(f"{to}: cannot write the export: {e.strerror}") from None
    click.echo(f"wrote {to / 'meta.json'} and {to / 'samples.csv'} ({data.t.size} rows)")
