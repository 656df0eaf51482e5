"""A session folder as the commands read it: the rig's own (`session.sqlite`) or an interchange one
(`meta.json` + `samples.csv`), so every command takes the folder the rig wrote without an export first."""

from __future__ import annotations

from pathlib import Path

from rig.errors import InputError
from rig.session_data import SessionData, with_configuration_facts


def is_rig_session(folder: Path) -> bool:
    from rig.store import SESSION_FILE

    return (Path(folder) / SESSION_FILE).is_file()


def read_any_session(folder: Path) -> SessionData:
    """The session in `folder`, whichever of the two layouts it is in; InputError naming the folder if neither."""
    folder = Path(folder)
    if is_rig_session(folder):
        from rig.store import SessionStore

        with SessionStore.open(folder) as store:
            return session_from_store(store)
    if (folder / "meta.json").is_file() or (folder / "samples.csv").is_file():
        from rig.io.session_csv import read_session

        return read_session(folder)
    raise InputError(f"{folder}: not a session folder (neither a rig session, session.sqlite, nor an interchange "
                     "session, meta.json + samples.csv)")


def session_kind(folder: Path) -> tuple[bool, list[str]] | None:
    """(has a turntable, its sensors) of an interchange session in `folder`, from meta.json alone: a command
    refuses a kind it cannot use before its samples are read (`rig.recording_kinds`). None for the rig's own
    folder (a turntable session, which every command takes) and for a folder without meta.json (the reader then
    says what it is not)."""
    folder = Path(folder)
    if is_rig_session(folder) or not (folder / "meta.json").is_file():
        return None
    from rig.io.session_meta import read_meta

    meta = read_meta(folder / "meta.json")
    return meta.get("reference", "table") != "none", list(meta["sensors"])


def session_from_store(store) -> SessionData:
    """The store's session with what the interchange layout carries beside the arrays (its configuration facts)."""
    return with_configuration_facts(store.to_session_data())
