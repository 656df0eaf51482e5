"""Worker pools, stop signals and dead workers (procedures.fork_pool).

A SIGTERM or Ctrl-C sent to the whole process group, as pkill, `kill -- -PGID`, a service manager or a terminal sends
it, reaches the workers too; a worker can also be killed outright (SIGKILL, the out-of-memory killer). Either could
leave a dead worker holding its pool's queue lock, and `multiprocessing.Pool` then waited for ever: `rig discrepancy
--heldout` hung. Each case runs in a process of its own with a deadline, so a hang fails the test rather than the
run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

POOL_SCRIPT = textwrap.dedent("""
    import multiprocessing as mp, os, signal, sys, time
    from procedures.fork_pool import ForkPool, WorkerDied
    from rig.errors import StopSignal

    def slow_square(x):
        time.sleep(0.05)
        return x * x

    def stop(signum, frame):
        raise StopSignal(signum)

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, stop)
    action = sys.argv[1]
    try:
        with ForkPool(2, "the test's squares") as pool:
            futures = [pool.submit(slow_square, x) for x in range(200)]
            time.sleep(0.5)
            workers = sorted(p.pid for p in mp.active_children())
            print("workers", *workers, flush=True)
            if action == "kill":
                os.kill(workers[0], signal.SIGKILL)
            elif action == "interrupt":
                for pid in workers:
                    os.kill(pid, signal.SIGINT)
                    os.kill(pid, signal.SIGHUP)
            elif action == "group":
                os.killpg(0, signal.SIGTERM)
            values = [pool.result(f) for f in futures]
        print("values", sum(values) == sum(x * x for x in range(200)), flush=True)
    except WorkerDied as exc:
        print("died", exc, flush=True)
    except StopSignal as exc:
        print("stopped", exc, flush=True)
    print("left", len(mp.active_children()), flush=True)
""")


def _run(action: str) -> tuple[dict, int]:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-c", POOL_SCRIPT, action], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise AssertionError(f"the pool hung after '{action}'") from None
    time.sleep(0.2)
    left_in_group = subprocess.run(["pgrep", "-g", str(proc.pid)], capture_output=True, text=True).stdout.split()
    lines = {line.split(" ", 1)[0]: line.split(" ", 1)[1] if " " in line else "" for line in out.splitlines()}
    assert "Traceback" not in err, err
    return lines, len(left_in_group)


def test_interrupts_sent_to_the_workers_are_left_to_the_parent():
    lines, left = _run("interrupt")
    assert lines.get("values") == "True", lines
    assert lines.get("left") == "0" and left == 0


def test_a_worker_killed_outright_ends_the_work_with_its_pid_and_signal():
    lines, left = _run("kill")
    killed = lines["workers"].split()[0]
    assert lines.get("died", "").startswith(f"worker process {killed} of the test's squares died of SIGKILL"), lines
    assert lines.get("left") == "0" and left == 0


def test_a_sigterm_to_the_whole_group_stops_the_parent_and_ends_every_worker():
    lines, left = _run("group")
    assert lines.get("stopped") == "SIGTERM", lines
    assert lines.get("left") == "0" and left == 0


def _die_of(signum: int) -> None:
    os.kill(os.getpid(), signum)


def test_work_given_after_a_worker_died_is_refused_naming_it_not_as_a_broken_pool():
    """Between two submits a worker can die (the replicas are all submitted at once): the next submit is refused
    with the worker's pid and signal, as the results are, not with the executor's own exception (an internal
    error to the user)."""
    from procedures.fork_pool import ForkPool, WorkerDied

    with ForkPool(1, "the test's work") as pool:
        first = pool.submit(_die_of, signal.SIGKILL)
        deadline = time.monotonic() + 30
        while not first.done() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert first.done()
        try:
            pool.submit(abs, -1)
        except WorkerDied as exc:
            assert "of the test's work died of SIGKILL" in str(exc), exc
        else:
            raise AssertionError("a pool whose worker died took more work")
