"""Mirroring a session into the central store while it runs, and pushing finished ones.

The mirror needs no hook in the acquisition code: it polls the session file (read-only; WAL lets it read
every commit while the rig writes) and pushes what is new. The rig never waits for the network.

A database that is away is asked again on a schedule that respects it and every other rig waiting for it
(`Backoff`): the wait doubles from 1 s up to 30 s, each drawn with jitter so that rigs cut off together do not
come back together, and no rig ever tries to connect more than once a second, while the session runs or after
it. A refusal that waiting cannot mend (a wrong password, a role or database that does not exist, a read-only
database, another schema, a unit claimed by another rig, a conflicting session, a file that breaks its format)
ends the mirror at once with its reason, in one line. In every case the session goes on locally and
`rig push DIR` finishes the job later.
"""

from __future__ import annotations

import contextlib
import math
import random
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import click

from rig.errors import RigError
from rig.exits import Exit, code_for
from rig.lab import identity
from rig.lab.errors import CorruptInput, PushRefused, StoreError, StoreInputError, StoreUnavailable, UnitClaimed, redact
from rig.lab.local import LocalSession
from rig.lab.pg import CONNECT_TIMEOUT_S, check_url, connect
from rig.lab.push import Pusher, PushResult
from rig.store.schema import SESSION_FILE

POLL_S = 0.2                   # how often the session file is looked at (local, no network)
FIRST_BACKOFF_S = 1.0          # the first wait after a failed connection
MAX_BACKOFF_S = 30.0           # the longest wait between two connection attempts
MIN_ATTEMPT_GAP_S = 1.05       # never two connection attempts of one mirror closer (1 s, with margin for jitter)
FINAL_PUSH_S = 15.0            # after the session ends, how long a reachable store is given to take the rest
WAIT_DOWN_S = 0.0              # after the session ends, how long a store that is away is waited for


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


class Backoff:
    """When the next connection attempt may be made: "equal jitter" exponential back-off (the wait after the
    n-th failure in a row is drawn uniformly from [c/2, c], c = min(first * 2^(n-1), cap)), never sooner than
    `gap_s` after the previous attempt, whatever its outcome."""

    def __init__(self, *, first_s: float = FIRST_BACKOFF_S, cap_s: float = MAX_BACKOFF_S,
                 gap_s: float = MIN_ATTEMPT_GAP_S, rng: random.Random | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.first_s, self.cap_s, self.gap_s = first_s, cap_s, gap_s
        self.rng, self.clock = rng or random.Random(), clock
        self.failures = 0
        self.last_attempt: float | None = None
        self.not_before = -math.inf

    def attempt(self) -> None:
        """A connection attempt starts now."""
        self.last_attempt = self.clock()
        self.not_before = self.last_attempt + self.gap_s

    def failed(self) -> float:
        """The attempt failed: the next one waits; returns that wait (from the attempt)."""
        self.failures += 1
        ceiling = min(self.cap_s, self.first_s * 2 ** (self.failures - 1))
        wait = max(self.gap_s, self.rng.uniform(ceiling / 2, ceiling))
        start = self.last_attempt if self.last_attempt is not None else self.clock()
        self.not_before = start + wait
        return wait

    def succeeded(self) -> None:
        self.failures = 0

    def ready_in(self) -> float:
        """Seconds until an attempt is allowed (0 when it is)."""
        return max(0.0, self.not_before - self.clock())


@dataclass
class MirrorOutcome:
    complete: bool = False            # everything the session recorded is in the store
    holds: int = 0                    # holds pushed by this mirror
    status: str = ""
    problem: str = ""                 # why it is not complete
    code: int = 0                     # the exit code of how it ended (rig.exits)
    lost_connection: int = 0          # how many times the database went away
    attempts: int = 0                 # connection attempts made
    log: list[str] = field(default_factory=list)


class SessionMirror:
    """Follows one session folder into the store until the session ends (or `stop` is set).

    After the session ends (its status final, or `stop` set) the mirror pushes what is left: for at most
    `final_push_s` while the store takes it, and waits at most `wait_down_s` for a store that is away (still
    on the back-off's schedule) before it says what is left for `rig push`; setting `wait_down_s` to 0 and
    `stop` ends a wait at once (Ctrl-C)."""

    def __init__(self, folder: str | Path, url: str, *, rig: str | None = None, poll_s: float = POLL_S,
                 echo: Callable[[str], None] = stderr, final_push_s: float = FINAL_PUSH_S,
                 wait_down_s: float = WAIT_DOWN_S, backoff: Backoff | None = None) -> None:
        self.folder, self.url, self.rig = Path(folder), url, rig
        self.poll_s, self.echo = poll_s, echo
        self.final_push_s, self.wait_down_s = final_push_s, wait_down_s
        self.backoff = backoff or Backoff()
        self.outcome = MirrorOutcome()

    def say(self, message: str) -> None:
        self.outcome.log.append(message)
        self.echo(message)

    def run(self, stop: threading.Event) -> MirrorOutcome:
        local = conn = pusher = None
        seen, down, ended = None, False, None
        try:
            while True:
                now = time.monotonic()
                if stop.is_set() and ended is None:
                    ended = now
                if ended is not None and not down and now > ended + self.final_push_s:
                    return self._gave_up("the session ended but the store did not take everything in time")
                if local is None:
                    local = self._open()
                    if local is None:
                        if ended is not None:
                            return self._gave_up("no session was created in the folder")
                        self._pause(stop, self.poll_s)
                        continue
                try:
                    ids, status = local.last_ids(), local.metadata().get("status", "")
                    if ended is None and status in identity.TERMINAL:
                        ended = now                      # the session is over: the store is waited for no longer
                    if conn is None:
                        wait = self.backoff.ready_in()
                        if ended is not None and down and now + wait > ended + self.wait_down_s:
                            return self._gave_up(self._down_reason)
                        if wait > 0:
                            self._pause(stop, min(wait, self.poll_s) if ended is None else wait)
                            continue
                        self.backoff.attempt()
                        self.outcome.attempts += 1
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
                    self.backoff.succeeded()
                    if status in identity.TERMINAL:
                        self.outcome.complete = True
                        self.say(f"{self.folder}: {self.outcome.status}; every hold is in {redact(self.url)}")
                        return self.outcome
                    if ended is not None:        # the process is ending: what was pushed is everything
                        self.outcome.complete = True
                        return self.outcome
                except StoreUnavailable as exc:
                    wait = self.backoff.failed()
                    if not down:
                        self.outcome.lost_connection += 1
                        self.say(f"{exc}; the session goes on recording locally in {self.folder} and is pushed "
                                 "when the store is back (next try in {:.0f} s, then at most every {:.0f} s)"
                                 .format(wait, self.backoff.cap_s))
                    self._down_reason = f"{exc}"
                    down = True
                    conn = _close(conn)
                    pusher = None
                    continue
                except CorruptInput as exc:              # refused whole: waiting will not mend it
                    return self._gave_up(str(exc), exc)
                except StoreInputError as exc:           # the file is being created: not readable yet
                    if ended is not None:
                        return self._gave_up(str(exc), exc)
                except (StoreError, PushRefused, UnitClaimed, RigError) as exc:
                    return self._gave_up(str(exc), exc)
                self._pause(stop, self.poll_s)
        finally:
            _close(conn)
            if local is not None:
                local.close()

    _down_reason = "the store cannot be reached"

    @staticmethod
    def _pause(stop: threading.Event, seconds: float) -> None:
        """Wait `seconds`; while the session runs its end wakes the mirror early (connection attempts stay on
        the back-off's schedule, which a wake-up does not change)."""
        if seconds <= 0:
            return
        if stop.is_set():
            time.sleep(seconds)
        else:
            stop.wait(seconds)

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

    def _gave_up(self, reason: str, exc: BaseException | None = None) -> MirrorOutcome:
        self.outcome.problem = reason
        self.outcome.code = code_for(exc) if exc is not None else Exit.FAILED
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
                final_push_s: float = FINAL_PUSH_S, wait_down_s: float = WAIT_DOWN_S) -> Iterator[SessionMirror]:
    """Mirror `session_dir` into `store_url` in a background thread for the duration of the block.

        with live_mirror(out, url):
            code = run_session_to(out, config, ...)

    On leaving, the mirror makes its last push (for at most `final_push_s`; a store that is away is waited for
    `wait_down_s`, by default not at all: the rig is not held up for it) and says what, if anything, is left
    for `rig push`. A store URL that can never work (a password in it) is refused before the session starts.
    """
    check_url(store_url)
    mirror = SessionMirror(session_dir, store_url, rig=rig, poll_s=poll_s, echo=echo, final_push_s=final_push_s,
                           wait_down_s=wait_down_s)
    stop = threading.Event()
    thread = threading.Thread(target=mirror.run, args=(stop,), name="rig-live-mirror", daemon=True)
    thread.start()
    try:
        yield mirror
    finally:
        stop.set()
        thread.join(final_push_s + wait_down_s + MAX_BACKOFF_S + 2 * CONNECT_TIMEOUT_S + 10.0)
        if thread.is_alive():
            mirror.say(f"the store {redact(store_url)} did not answer in time; push the session later with "
                       f"`rig push {session_dir} --store {redact(store_url)}`")
