"""Worker processes forked from the process that holds the work (a twin's replicas, its held-out refits beside
them): how they take stop signals, and what a worker's death becomes.

A stop signal is the parent's to act on. Ctrl-C reaches the whole process group, and so does a SIGTERM sent by
`pkill`, `kill -- -PGID` or a service manager stopping its unit. The workers ignore SIGINT and SIGHUP (a
KeyboardInterrupt in an idle worker would print a traceback) and die of SIGTERM by its default, silently; the
parent ends them with it on its way out. The stop signals are blocked while the pool forks, so none reaches a worker
before it has these dispositions; one that arrives meanwhile waits and reaches the parent once they are unblocked.

A worker can die while its pool needs it: killed outright (SIGKILL, the kernel's out-of-memory killer), or of a
SIGTERM sent to it alone. A dead worker can hold its queue's lock, and `multiprocessing.Pool` then waits for ever.
`ProcessPoolExecutor` watches its workers and fails the pending work when one dies; that is turned into `WorkerDied`, naming the process
and its signal, which the commands report as a failure (exit 3).
"""

from __future__ import annotations

import multiprocessing as mp
import signal
from collections.abc import Callable, Iterable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from rig.errors import RigError, signal_name

STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGHUP", "SIGTERM") if hasattr(signal, name))


class WorkerDied(RigError):
    """A worker process died before it returned its work; names the process and how it died."""


class ForkPool:
    """`processes` forked workers that leave stop signals to this process. `close()` (or the end of a `with` block)
    lets them finish, or, when the work was abandoned (an error or a stop signal on its way out), terminates them.
    Callers check `fork_available()` first."""

    def __init__(self, processes: int, purpose: str = "the work") -> None:
        self.purpose = purpose
        self._executor: ProcessPoolExecutor | None = ProcessPoolExecutor(
            processes, mp_context=mp.get_context("fork"), initializer=_leave_stop_signals_to_parent)
        self._workers: list[mp.process.BaseProcess] = []

    def submit(self, fn: Callable, *args) -> Future:
        """`fn(*args)` in a worker; WorkerDied where one has already died (the pool takes no more work then)."""
        if self._workers:
            try:
                return self._executor.submit(fn, *args)
            except BrokenProcessPool:
                raise self._death() from None
        before = set(mp.active_children())
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        try:                                        # the first submit forks every worker
            return self._executor.submit(fn, *args)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
            self._workers = [p for p in mp.active_children() if p not in before]

    def result(self, future: Future) -> object:
        """The future's value, or WorkerDied where a worker died before it was returned."""
        try:
            return future.result()
        except BrokenProcessPool:
            raise self._death() from None

    def map(self, fn: Callable, items: Iterable) -> list:
        futures = [self.submit(fn, item) for item in items]
        return [self.result(f) for f in futures]

    def close(self, abandon: bool = False) -> None:
        if self._executor is None:
            return
        if abandon:
            for p in self._workers:
                if p.is_alive():
                    p.terminate()
        self._executor.shutdown(wait=True, cancel_futures=abandon)
        self._executor = None

    def __enter__(self) -> "ForkPool":
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.close(abandon=exc_type is not None)

    def _death(self) -> WorkerDied:
        """Which worker died, and how: the pool ends the others with SIGTERM once one has died, so a death by any
        other signal or status names its worker; deaths by SIGTERM alone name the one seen dead first, or all."""
        dead = [p.pid for p in self._workers if p.exitcode is not None]     # before the broken pool ends the rest
        self.close()
        codes = {p.pid: p.exitcode for p in self._workers}
        own = [pid for pid, code in codes.items() if code != -signal.SIGTERM]
        pids = own[:1] or (dead if len(dead) == 1 else sorted(codes))
        code = codes[pids[0]]
        how = f"of {signal_name(-code)}" if code is not None and code < 0 else f"with exit status {code}"
        hint = " (as the kernel's out-of-memory killer kills)" if code == -signal.SIGKILL else ""
        who = (f"worker process {pids[0]}" if len(pids) == 1
               else f"one of the worker processes {', '.join(map(str, pids))}")
        return WorkerDied(f"{who} of {self.purpose} died {how}{hint} before it returned its work; nothing was written")


def fork_available() -> bool:
    return "fork" in mp.get_all_start_methods() and hasattr(signal, "pthread_sigmask")


def _leave_stop_signals_to_parent() -> None:
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_DFL if sig == signal.SIGTERM else signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
