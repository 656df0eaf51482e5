"""Mirroring a session into the central store while it runs, and pushing finished ones.

The mirror needs no hook in the acquisition code: it polls the session file (read-only; WAL lets it read
every commit while the rig writes) and pushes what is new. The rig never waits for the network. When the
database refuses or drops the connection the mirror says so once, keeps polling with a growing pause and
pushes everything when the database is back; a refusal that will not go away by waiting (read-only database,
another schema, a unit claimed by another rig, a conflicting session) ends the mirror with its reason. In
every case the session goes on locally and `rig push DIR` finishes the job later.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import click

from rig.lab import identity
from rig.lab.errors import PushRefused, StoreError, StoreInputError, StoreUnavailable, UnitClaimed, redact
from rig.lab.local import LocalSession
from rig.lab.pg import connect
from rig.lab.push import Pusher, PushResult
from rig.store.schema import SESSION_FILE

POLL_S = 0.2
MAX_BACKOFF_S = 5.0
FINAL_PUSH_S = 15.0            # after the session ends, how long the mirror keeps trying before it gives up


def stderr(message: str) -> None:
    click.echo(message, err=True)


def push_folder(folder: str | Path, url: str, *, rig: str | None = None, conn=None) -> PushResult:
    """Push one session folder; a connection may be shared between folders (`rig push --all`)."""
    with LocalSession.open(folder) as local:
        own = conn is None
        conn = conn if conn is not None else connect(url)
        try:
            return Pusher(local, conn, url, rig=rig).push()
        finally:
            if own:
                conn.close()


@dataclass
class MirrorOutcome:
    complete: bool = False            # everything the session recorded is in the store
    holds: int = 0                    # holds pushed by this mirror
    status: str = ""
    problem: str = ""                 # why it is not complete
    lost_connection: int = 0          # how many times the database went away
    log: list[str] = field(default_factory=list)


class SessionMirror:
    """Follows one session folder into the store until the session ends (or `stop` is set)."""

    def __init__(self, folder: str | Path, url: str, *, rig: str | None = None, poll_s: float = POLL_S,
                 echo: Callable[[str], None] = stderr, final_push_s: float = FINAL_PUSH_S) -> None:
        self.folder, self.url, self.rig = Path(folder), url, rig
        self.poll_s, self.echo, self.final_push_s = poll_s, echo, final_push_s
        self.outcome = MirrorOutcome()

    def say(self, message: str) -> None:
        self.outcome.log.append(message)
        self.echo(message)

    def run(self, stop: threading.Event) -> MirrorOutcome:
        local = conn = pusher = None
        seen, backoff, down, deadline = None, self.poll_s, False, None
        try:
            while True:
                if stop.is_set() and deadline is None:
                    deadline = time.monotonic() + self.final_push_s
                if deadline is not None and time.monotonic() > deadline:
                    return self._gave_up("the session ended but the store did not take everything in time")
                if local is None:
                    local = self._open()
                    if local is None:
                        if deadline is not None:
                            return self._gave_up("no session was created in the folder")
                        stop.wait(self.poll_s)
                        continue
                try:
                    ids, status = local.last_ids(), local.metadata().get("status", "")
                    if conn is None:
                        conn = connect(self.url)
                        pusher = Pusher(local, conn, self.url, rig=self.rig)
                        if down:
                            self.say(f"store {redact(self.url)} is back: pushing what was recorded meanwhile")
                        down, seen = False, None
                    if ids != seen:
                        result = pusher.push()
                        self.outcome.holds += result.holds
                        self.outcome.status = result.status
                        seen = ids
                    backoff = self.poll_s
                    if status in identity.TERMINAL:
                        self.outcome.complete = True
                        self.say(f"{self.folder}: {self.outcome.status}; every hold is in {redact(self.url)}")
                        return self.outcome
                    if deadline is not None:        # the process is ending: what was pushed is everything
                        self.outcome.complete = True
                        return self.outcome
                except StoreUnavailable as exc:
                    if not down:
                        self.outcome.lost_connection += 1
                        self.say(f"{exc}; the session goes on recording locally in {self.folder} and is pushed "
                                 "when the store is back")
                    down = True
                    conn = _close(conn)
                    pusher = None
                    stop.wait(backoff)
                    backoff = min(backoff * 2, MAX_BACKOFF_S)
                    continue
                except StoreInputError as exc:           # the file is being created: not readable yet
                    if deadline is not None:
                        return self._gave_up(str(exc))
                except StoreError as exc:
                    return self._gave_up(str(exc))
                except (PushRefused, UnitClaimed) as exc:
                    return self._gave_up(str(exc))
                stop.wait(self.poll_s)
        finally:
            _close(conn)
            if local is not None:
                local.close()

    def _open(self) -> LocalSession | None:
        if not (self.folder / SESSION_FILE).is_file():
            return None
        try:
            local = LocalSession.open(self.folder)
            local.key()
            local.last_ids()
            return local
        except StoreInputError:
            return None

    def _gave_up(self, reason: str) -> MirrorOutcome:
        self.outcome.problem = reason
        self.say(f"{reason}; the session is recorded locally: push it later with "
                 f"`rig push {self.folder} --store {redact(self.url)}`")
        return self.outcome


def _close(conn) -> None:
    if conn is not None:
        with contextlib.suppress(Exception):
            conn.close()
    return None


@contextlib.contextmanager
def live_mirror(session_dir: str | Path, store_url: str, *, rig: str | None = None,
                echo: Callable[[str], None] = stderr, poll_s: float = POLL_S,
                final_push_s: float = FINAL_PUSH_S) -> Iterator[SessionMirror]:
    """Mirror `session_dir` into `store_url` in a background thread for the duration of the block.

        with live_mirror(out, url):
            code = run_session_to(out, config, ...)

    On leaving, the mirror makes its last push (for at most `final_push_s`) and says what, if anything,
    is left for `rig push`.
    """
    mirror = SessionMirror(session_dir, store_url, rig=rig, poll_s=poll_s, echo=echo, final_push_s=final_push_s)
    stop = threading.Event()
    thread = threading.Thread(target=mirror.run, args=(stop,), name="rig-live-mirror", daemon=True)
    thread.start()
    try:
        yield mirror
    finally:
        stop.set()
        thread.join(final_push_s + 2 * MAX_BACKOFF_S + 10.0)
        if thread.is_alive():
            mirror.say(f"the store {redact(store_url)} did not answer in time; push the session later with "
                       f"`rig push {session_dir} --store {redact(store_url)}`")
