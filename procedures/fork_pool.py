"""Worker processes forked from the process that holds the work (a twin's replicas, its held-out refits beside
them), and how they take stop signals.

A stop signal is the parent's to act on. Ctrl-C reaches the whole process group, and so does a SIGTERM sent by
`pkill`, `kill -- -PGID` or a service manager stopping its unit. A worker that died of such a SIGTERM could die
holding its pool's queue lock; the pool then forked a replacement that waited on that lock for ever, and so did the
parent ending the pool: `rig discrepancy --heldout` hung after a SIGTERM to its group (2026-11-27, at 4 s into the
Xsens). So a worker ignores SIGINT and SIGHUP, and takes SIGTERM only once its parent has begun to end the pool,
which is how the parent ends it (`Pool.terminate`). The stop signals are blocked while a pool forks, so none reaches
a worker before it has these handlers (it would find the parent's, which raise); one that arrives meanwhile waits
and reaches the parent once they are unblocked.
"""

from __future__ import annotations

import multiprocessing as mp
import multiprocessing.pool
import os
import signal

STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGHUP", "SIGTERM") if hasattr(signal, name))


class ForkPool:
    """A pool of `processes` forked workers that leave stop signals to this process; ended (`close`, or the end of
    a `with` block, which gives the pool) by terminating them. Callers check `fork_available()` first."""

    def __init__(self, processes: int) -> None:
        ctx = mp.get_context("fork")
        self._ending = ctx.RawValue("b", 0)
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
        try:
            self.pool: mp.pool.Pool | None = ctx.Pool(processes, initializer=_leave_stop_signals_to_parent,
                                                      initargs=(self._ending, blocked))
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)

    def close(self) -> None:
        if self.pool is not None:
            self._ending.value = 1
            self.pool.terminate()
            self.pool.join()
            self.pool = None

    def __enter__(self) -> mp.pool.Pool:
        return self.pool

    def __exit__(self, *exc) -> None:
        self.close()


def fork_available() -> bool:
    return "fork" in mp.get_all_start_methods() and hasattr(signal, "pthread_sigmask")


def _leave_stop_signals_to_parent(ending, mask: set) -> None:
    for sig in STOP_SIGNALS:
        if sig == signal.SIGTERM:
            signal.signal(sig, lambda signum, frame: os._exit(128 + signum) if ending.value else None)
        else:
            signal.signal(sig, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
