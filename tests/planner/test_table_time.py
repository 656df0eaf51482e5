"""calibration.json records the table time the session used (`table_time_s`)."""

import json

import numpy as np

from rig.calibration.numerics.result import TriadCalibration
from rig.pipeline.result import SessionCalibration
from rig.pipeline.writing import table_time_s, write_session_calibration
from rig.session_data import SessionData


def session(segments, meta=None) -> SessionData:
    """Rows at 100 Hz for each (phase, step, t_start, t_end) segment."""
    t, is_move, step = [], [], []
    for phase, j, a, b in segments:
        ts = np.arange(a, b + 1e-9, 0.01)
        t.append(ts)
        is_move.append(np.full(ts.size, phase == "move"))
        step.append(np.full(ts.size, j))
    t = np.concatenate(t)
    n = t.size
    q = np.tile([1.0, 0, 0, 0], (n, 1))
    return SessionData(t=t, is_move=np.concatenate(is_move), step=np.concatenate(step), q_ref=q,
                       raw={"accel": np.zeros((n, 3))}, columns={"accel": ["ax", "ay", "az"]}, meta=meta or {})


def test_table_time_runs_from_the_first_hold_to_the_end_of_the_last():
    s = session([("hold", 0, 2.0, 7.0), ("move", 0, 7.01, 9.0), ("hold", 1, 9.01, 14.0), ("move", 1, 14.01, 15.5)])
    # the move after the last hold was interrupted: it is not table time the calibration used
    assert table_time_s(s) == 12.0


def test_a_repeated_hold_counts_and_a_resume_gap_does_not():
    # hold 1 was repeated (its first attempt, 9-14 s, is not stored; the session clock ran on), then the run
    # was interrupted after hold 1 and resumed 1 s of session clock later, holding again at 1
    segments = [("hold", 0, 0.0, 5.0), ("move", 0, 5.01, 9.0), ("hold", 1, 14.01, 19.0),
                ("hold", 1, 20.0, 25.0), ("move", 1, 25.01, 27.0), ("hold", 2, 27.01, 32.0)]
    s = session(segments, {"resumes": [{"t_s": 20.0, "after_s": 19.0}]})
    assert table_time_s(s) == 31.0


def test_no_table_no_table_time(tmp_path):
    s = session([("hold", 0, 0.0, 5.0)], {"reference": "none"})
    assert table_time_s(s) is None
    cal = TriadCalibration(B=np.zeros(3), H=np.eye(3), method="joint")
    path = write_session_calibration(tmp_path, SessionCalibration({"accel": cal}), gravity=9.8, field_uT=None,
                                     session=s)
    assert json.loads(path.read_text())["table_time_s"] is None


def test_the_writer_puts_it_at_the_top_level(tmp_path):
    s = session([("hold", 0, 0.0, 5.0), ("move", 0, 5.01, 6.0), ("hold", 1, 6.01, 11.0)])
    cal = TriadCalibration(B=np.zeros(3), H=np.eye(3), method="joint")
    path = write_session_calibration(tmp_path, SessionCalibration({"accel": cal}), gravity=9.8, field_uT=None,
                                     session=s)
    doc = json.loads(path.read_text())
    assert doc["table_time_s"] == 11.0
    assert doc["schema"] == "rig-calibration/1"
