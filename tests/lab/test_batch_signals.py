"""Ctrl-C on `rig batch`: Ctrl-C reaches the whole process group, the local Dask cluster's workers too."""

from __future__ import annotations

import os
import signal
import subprocess

from .conftest import RIG, make_archive


def test_ctrl_c_during_a_batch_ends_it_with_one_line_not_the_workers_tracebacks(tmp_path):
    """The workers ignore SIGINT and the rig process stops and closes the cluster, exit 130 with one line; before,
    each Dask worker printed its KeyboardInterrupt traceback on the user's terminal."""
    make_archive(tmp_path / "store", [dict(unit="U", rig="rig-a", unit_seed=5, start_utc=f"2026-02-{1 + i:02d}T08:00:00.000Z")
                                       for i in range(16)])
    proc = subprocess.Popen([*RIG, "batch", "discrepancy", "--store", str(tmp_path / "store"), "--replay"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    first = proc.stdout.readline()
    assert " sessions on " in first, (first, proc.stderr.read() if proc.poll() is not None else "")
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (proc.returncode, out, err)
    assert "Traceback" not in err and err.strip().splitlines() == ["aborted"], err
