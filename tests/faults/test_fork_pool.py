"""Worker pools and stop signals (procedures.fork_pool): a SIGTERM or Ctrl-C sent to the whole process group, as
pkill, `kill -- -PGID`, a service manager or a terminal sends it, reaches the workers too. They leave it to the
parent, so none dies holding the pool's queue lock (the pool had then forked a replacement that waited on that lock
for ever, and `rig discrepancy --heldout` hung), and the parent still ends them."""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import time

from procedures.fork_pool import ForkPool


def _slow_square(x: int) -> int:
    time.sleep(0.05)
    return x * x


def test_a_stop_signal_sent_to_the_workers_is_left_to_the_parent_and_closing_still_ends_them():
    others = {p.pid for p in mp.active_children()}         # whatever earlier tests in this process left running

    def pool_workers():
        return sorted(p.pid for p in mp.active_children() if p.pid not in others)

    with ForkPool(2) as pool:
        result = pool.map_async(_slow_square, range(40), chunksize=1)
        time.sleep(0.3)
        workers = pool_workers()
        assert len(workers) == 2
        for pid in workers:
            os.kill(pid, signal.SIGTERM)
            os.kill(pid, signal.SIGINT)
        assert result.get(timeout=60) == [x * x for x in range(40)]
        assert pool_workers() == workers                       # none died, none was replaced
    assert not pool_workers()
