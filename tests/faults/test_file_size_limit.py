"""The disk filling as CI can make it without privileges: a file-size limit on the rig process (RLIMIT_FSIZE, so
writes fail with EFBIG). The session fails truthfully (exit 3, the cause named, what was recorded kept), and
`rig resume` finishes it once the limit is lifted. (A full tmpfs, ENOSPC, is in test_exits.py where a private
mount is allowed.)"""

from __future__ import annotations

import resource
import subprocess
import sys

from rig.store import SessionStore

RIG = [sys.executable, "-m", "rig.cli"]


def test_a_file_size_limit_fails_the_session_naming_it_and_resume_finishes_it(tmp_path):
    out = tmp_path / "s"

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (450_000, 450_000))

    first = subprocess.run([*RIG, "calibrate", "--sim", "--orientations", "12", "--no-progress", "--out", str(out)],
                           capture_output=True, text=True, timeout=300, preexec_fn=limit)
    assert first.returncode == 3, first.stderr
    assert "Traceback" not in first.stdout + first.stderr
    assert "file-size limit" in first.stderr and "450000 bytes" in first.stderr, first.stderr
    with SessionStore.open(out) as store:
        status, reason = store.status
        kept = store.completed_holds()
    assert status == "failed" and "file-size limit" in reason
    assert 0 < len(kept) < 12
    again = subprocess.run([*RIG, "resume", str(out), "--no-progress"], capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    with SessionStore.open(out) as store:
        assert store.status[0] == "complete"
        assert [j for j, _ in store.to_session_data().hold_rows()] == list(range(12))
