"""`rig batch` on a store with nothing it can analyse: the exit says so, and names what the folder holds."""

from __future__ import annotations

import numpy as np

from rig.io.recording import recording_session
from rig.io.session_writer import write_session

from .conftest import make_archive, no_traceback, rig


def test_a_folder_of_imported_recordings_is_named_and_refused_not_reported_as_an_empty_match(tmp_path):
    """Batch reads sessions recorded by rig; a folder of interchange recordings (what `rig import` writes) had
    said "no session matches" and exited 0, as if there were nothing to do."""
    t = np.arange(300) / 100.0
    still = np.tile([0.0, 0.0, 9.81], (len(t), 1))
    session = recording_session(t, {"accel": still, "gyro": np.zeros((len(t), 3))},
                                units={"accel": "m/s^2", "gyro": "deg/s"}, source="<log>", sample_rate_hz=100.0)
    folder = write_session(session, tmp_path / "store" / "bench-log")
    done = rig("batch", "discrepancy", "--store", tmp_path / "store")
    no_traceback(done)
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "1 interchange recording" in done.stderr and str(folder) in done.stderr, done.stderr

    (tmp_path / "empty").mkdir()
    done = rig("batch", "calibrate", "--store", tmp_path / "empty")
    assert done.returncode == 2 and "no session recorded by rig" in done.stderr, done.stderr


def test_a_where_that_matches_none_of_the_sessions_is_an_empty_result_exit_0(tmp_path):
    make_archive(tmp_path / "store", [dict(unit="U1", rig="rig-a", start_utc="2026-02-01T08:00:00.000Z")])
    done = rig("batch", "calibrate", "--store", tmp_path / "store", "--where", "unit=U2",
               "--json", tmp_path / "out.json")
    no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert "no session in" in done.stdout and "unit=U2" in done.stdout
    assert '"sessions": 0' in (tmp_path / "out.json").read_text()
