"""`rig export SESSION --to DIR`: a recorded session in the interchange layout (`imu-session-csv/1`).

A session still being recorded (its folder's lock held by another process), or one left running by an
interrupted process, is exported as far as it goes, and the command says so: such an export is not the
whole session.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
from pathlib import Path

import click

from rig.exits import CommandError, Exit, command_error

EXPORTED = ("meta.json", "samples.csv")


def recording_holder(folder: Path) -> str | None:
    """Who is recording into the session folder now ("pid N on HOST (COMMAND) since T"), or None. The
    folder's lock is only looked at (a shared lock tried, never taken over, nothing written)."""
    from rig.locks import SESSION_LOCK, describe_holder

    try:
        fd = os.open(Path(folder) / SESSION_LOCK, os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                return None
            try:
                holder = json.loads(os.pread(fd, 4096, 0).decode("utf-8", "replace") or "{}")
            except ValueError:
                holder = {}
            return describe_holder(holder if isinstance(holder, dict) else {})
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def unfinished(folder: Path, meta: dict, what: str, holds: int) -> str | None:
    """A warning line when the session in `folder` is not finished: `what` holds only part of it."""
    holder = recording_holder(folder)
    if holder is not None:
        return (f"warning: {folder} is still being recorded by {holder}: {what} holds the {holds} holds recorded "
                "so far, not the whole session")
    if meta.get("status") == "running":
        return (f"warning: {folder} was interrupted (status running, no process recording it): {what} holds the "
                f"{holds} holds recorded; `rig resume {folder}` finishes the session")
    return None


@click.command()
@click.argument("session", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--to", "to", required=True, type=click.Path(file_okay=False, path_type=Path))
@click.option("--force", is_flag=True, help="Replace an interchange session already in the --to folder.")
def export(session, to, force):
    """Write the session in SESSION as meta.json + samples.csv in the folder given by --to."""
    from rig.commands.common import session_from_store
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
            holds = len(store.completed_holds())
        warning = unfinished(session, meta, "the export", holds)
        extra = {k: meta[k] for k in ("unit", "operator", "start_utc", "end_utc", "status", "software", "truth",
                                      "verdict", "resumes") if k in meta}
        write_session(data, to, extra_meta={"rig_session": extra})
    except RigError as e:
        raise command_error(e) from None
    except OSError as e:
        raise CommandError(f"{to}: cannot write the export: {e.strerror}") from None
    if warning:
        click.echo(warning, err=True)
    click.echo(f"wrote {to / 'meta.json'} and {to / 'samples.csv'} ({data.t.size} rows)")
