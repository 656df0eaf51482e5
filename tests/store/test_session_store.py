"""Round trip, repeated holds, metadata/status, WAL mode and clear errors of `SessionStore`."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest
from synthetic_holds import hold_arrays, move_arrays

from rig.store import SESSION_FILE, NotASession, SessionStore, SessionStoreError, schema
from rig.store.sqlite_file import PARTIAL_SUFFIX

N_STEPS = 4
META = {"operator": "ana", "unit_serial": "BSN-0042", "gravity_mps2": 9.81, "field_uT": 48.5,
        "sample_rate_hz": 100, "truth": {"sensors": {"accel": {"B": np.array([1.0, 2.0, 3.0])}}}}


def _write_session(folder, steps=N_STEPS):
    store = SessionStore.create(folder, META)
    for step in range(steps):
        store.append_hold(step, **hold_arrays(step))
        if step < steps - 1:
            store.append_move(step, **move_arrays(step))
    return store


def _expected_rows(steps=N_STEPS):
    """The segments in time order as written: hold 0, move 0, hold 1, ..."""
    segments = []
    for step in range(steps):
        segments.append(("hold", step, hold_arrays(step)))
        if step < steps - 1:
            segments.append(("move", step, move_arrays(step)))
    return segments


@pytest.mark.parametrize("reopen", [False, True])
def test_round_trip_keeps_every_cell(tmp_path, reopen):
    store = _write_session(tmp_path / "s")
    if reopen:
        store.close()
        store = SessionStore.open(tmp_path / "s")
    data = store.to_session_data()
    store.close()

    segments = _expected_rows()
    np.testing.assert_array_equal(data.t, np.concatenate([a["t"] for _, _, a in segments]))
    np.testing.assert_array_equal(data.is_move, np.concatenate([np.full(a["t"].size, p == "move") for p, _, a in segments]))
    np.testing.assert_array_equal(data.step, np.concatenate([np.full(a["t"].size, s) for _, s, a in segments]))
    np.testing.assert_array_equal(data.q_ref, np.concatenate([a["q_ref"] for _, _, a in segments]))
    np.testing.assert_array_equal(data.table_deg, np.concatenate([a["table_deg"] for _, _, a in segments]))
    for sensor in ("accel", "gyro"):
        np.testing.assert_array_equal(data.raw[sensor], np.concatenate([a["samples"][sensor] for _, _, a in segments]))
    # mag is absent from moves: NaN rows there; within holds every other row is NaN (50 Hz)
    mag = np.concatenate([a["samples"].get("mag", np.full((a["t"].size, 3), np.nan)) for _, _, a in segments])
    np.testing.assert_array_equal(data.raw["mag"], mag)
    temp = np.concatenate([a.get("temp_c", np.full(a["t"].size, np.nan)) for _, _, a in segments])
    np.testing.assert_array_equal(data.temp_c, temp)
    assert data.columns == {"accel": ["ax", "ay", "az"], "gyro": ["gx", "gy", "gz"], "mag": ["mx", "my", "mz"]}
    assert (data.gravity, data.field_uT, data.sample_rate_hz) == (9.81, 48.5, 100.0)
    assert data.meta["truth"]["sensors"]["accel"]["B"] == [1.0, 2.0, 3.0]
    assert [j for j, _ in data.hold_rows()] == list(range(N_STEPS))


def test_repeated_hold_uses_latest_attempt_and_keeps_the_first_in_file(tmp_path):
    store = _write_session(tmp_path / "s", steps=2)
    store.append_hold(1, **hold_arrays(1, attempt=2))
    data = store.to_session_data()
    assert store.completed_holds() == [0, 1]
    store.close()

    rows = np.flatnonzero(~data.is_move & (data.step == 1))
    np.testing.assert_array_equal(data.raw["accel"][rows], hold_arrays(1, attempt=2)["samples"]["accel"])
    assert rows.size == hold_arrays(1)["t"].size
    db = sqlite3.connect(tmp_path / "s" / SESSION_FILE)
    assert db.execute("SELECT attempt FROM segment WHERE phase='hold' AND step=1 ORDER BY id").fetchall() == [(1,), (2,)]


def test_the_last_committed_hold_wins_whatever_its_attempt_number(tmp_path):
    store = SessionStore.create(tmp_path / "s", META)
    store.append_hold(0, **hold_arrays(0, attempt=2))
    again = hold_arrays(0, attempt=3)
    again["attempt"] = 1                      # a resumed run counts attempts from 1 again
    store.append_hold(0, **again)
    data = store.to_session_data()
    store.close()
    np.testing.assert_array_equal(data.raw["gyro"], again["samples"]["gyro"])


def test_hold_summary_rows_match_the_samples(tmp_path):
    _write_session(tmp_path / "s", steps=1).close()
    held = hold_arrays(0)
    db = sqlite3.connect(tmp_path / "s" / SESSION_FILE)
    stats = {ch: (mean, std, n) for ch, mean, std, n in db.execute("SELECT channel, mean, std, count FROM hold_stat")}
    mag_present = held["samples"]["mag"][~np.isnan(held["samples"]["mag"][:, 0])]
    assert stats["mz"][2] == held["t"].size // 2
    assert stats["mz"][0] == pytest.approx(mag_present[:, 2].mean())
    assert stats["ay"][1] == pytest.approx(held["samples"]["accel"][:, 1].std(ddof=1))
    assert stats["temp_c"][0] == pytest.approx(held["temp_c"].mean())


def test_wal_journal_and_full_sync(tmp_path):
    store = _write_session(tmp_path / "s", steps=1)
    assert (tmp_path / "s" / (SESSION_FILE + "-wal")).exists()
    assert store._conn.execute("PRAGMA synchronous").fetchone() == (2,)   # 2 = FULL
    store.close()
    assert sqlite3.connect(tmp_path / "s" / SESSION_FILE).execute("PRAGMA journal_mode").fetchone() == ("wal",)


def test_metadata_history_and_status(tmp_path):
    store = _write_session(tmp_path / "s", steps=1)
    assert store.status == ("running", "")
    store.update_metadata(calibration={"accel": {"residual_rms": 0.01}}, operator="bo")
    store.log_event("hold-repeated", "bump at step 0", t=1.5)
    store.set_status("aborted", "operator pressed stop")
    store.close()

    store = SessionStore.open(tmp_path / "s")
    meta = store.metadata
    assert store.status == ("aborted", "operator pressed stop")
    assert meta["operator"] == "bo" and meta["unit_serial"] == "BSN-0042"
    assert meta["calibration"]["accel"]["residual_rms"] == 0.01
    assert "end_utc" in meta and meta["start_utc"] <= meta["end_utc"]
    assert [(e["kind"], e["t"]) for e in store.events()] == [("hold-repeated", 1.5), ("status", None)]
    operators = store._conn.execute("SELECT value FROM metadata WHERE key='operator' ORDER BY id").fetchall()
    assert operators == [('"ana"',), ('"bo"',)]
    with pytest.raises(ValueError, match="status 'done'"):
        store.set_status("done")
    store.close()


def test_time_running_backwards_is_refused(tmp_path):
    """A resumed run that restarted its clock at 0 would interleave with the first run's rows."""
    store = _write_session(tmp_path / "s", steps=3)
    restarted = hold_arrays(3)
    restarted["t"] = restarted["t"] - restarted["t"][0]
    with pytest.raises(ValueError, match=r"append_hold\(step=3\): t starts at 0.0 s, before the end"):
        store.append_hold(3, **restarted)
    assert store.completed_holds() == [0, 1, 2]
    store.close()


def test_last_time_for_resume(tmp_path):
    store = _write_session(tmp_path / "s", steps=2)
    assert store.last_time() == hold_arrays(1)["t"][-1]
    store.close()


def test_create_refuses_an_existing_session(tmp_path):
    _write_session(tmp_path / "s", steps=1).close()
    with pytest.raises(SessionStoreError, match="already exists"):
        SessionStore.create(tmp_path / "s", META)


def test_open_missing_folder_and_file(tmp_path):
    with pytest.raises(SessionStoreError, match="no such session folder"):
        SessionStore.open(tmp_path / "nowhere")
    (tmp_path / "empty").mkdir()
    with pytest.raises(SessionStoreError, match="not a rig session"):
        SessionStore.open(tmp_path / "empty")
    assert not (tmp_path / "empty" / SESSION_FILE).exists()


def test_open_rejects_a_file_that_is_not_sqlite(tmp_path):
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / SESSION_FILE).write_bytes(b"t,phase,step\n0.0,hold,0\n" * 100)
    with pytest.raises(SessionStoreError, match=rf"{SESSION_FILE}.*not a readable SQLite"):
        SessionStore.open(tmp_path / "s")


def test_open_rejects_another_programs_sqlite(tmp_path):
    (tmp_path / "s").mkdir()
    db = sqlite3.connect(tmp_path / "s" / SESSION_FILE)
    db.execute("CREATE TABLE t (x)")
    db.commit()
    db.close()
    with pytest.raises(SessionStoreError, match="not a rig session"):
        SessionStore.open(tmp_path / "s")


def test_open_rejects_a_corrupted_session(tmp_path):
    _write_session(tmp_path / "s", steps=3).close()
    path = tmp_path / "s" / SESSION_FILE
    raw = bytearray(path.read_bytes())
    page = 4096
    raw[2 * page: 6 * page] = np.random.default_rng(7).integers(0, 256, 4 * page, dtype=np.uint8).tobytes()
    path.write_bytes(bytes(raw))
    with pytest.raises(SessionStoreError, match="corrupt session file"):
        SessionStore.open(tmp_path / "s")


@pytest.mark.parametrize("change, message", [
    (lambda a: a["samples"].update(mag=a["samples"]["mag"][:, :2]), r"samples\['mag'\] has shape \(500, 2\)"),
    (lambda a: a.update(t=a["t"][::-1].copy()), "t decreases at row 1"),
    (lambda a: a["samples"]["accel"].__setitem__((7, 1), np.nan), r"samples\['accel'\] row 7 is NaN on some axes"),
    (lambda a: a["q_ref"].__setitem__((4, 0), 3.0), "q_ref row 4 is not a unit quaternion"),
    (lambda a: a.update(commanded_deg=(1.0,)), "commanded_deg must be"),
])
def test_bad_hold_is_refused_and_nothing_written(tmp_path, change, message):
    store = SessionStore.create(tmp_path / "s", META)
    arrays = hold_arrays(0)
    change(arrays)
    with pytest.raises(ValueError, match=r"append_hold\(step=0, attempt=1\).*" + message):
        store.append_hold(0, **arrays)
    assert store.completed_holds() == []
    store.close()


def test_unserialisable_metadata_names_the_key(tmp_path):
    with pytest.raises(ValueError, match="metadata key 'driver'"):
        SessionStore.create(tmp_path / "s", {"driver": object()})


def test_closed_store_says_so(tmp_path):
    store = _write_session(tmp_path / "s", steps=1)
    store.close()
    with pytest.raises(SessionStoreError, match="closed"):
        store.completed_holds()


def test_a_create_stopped_part_way_leaves_no_session_file(tmp_path, monkeypatch):
    """A stop signal at start-up, while the session file was being set up, left an SQLite file without the
    session's identity: `rig resume` refused it as not a session, and so did `rig calibrate --out` (found by the
    fault campaign). The file is whole or not there."""
    monkeypatch.setattr(schema, "DDL", schema.DDL + ";\nCREATE TABLE broken (")   # fails part way
    with pytest.raises(SessionStoreError, match=SESSION_FILE):
        SessionStore.create(tmp_path, {"serial": "X"})
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    monkeypatch.undo()
    (tmp_path / (SESSION_FILE + PARTIAL_SUFFIX)).write_bytes(b"left by a killed create")
    with pytest.raises(NotASession, match="no session.sqlite"):
        SessionStore.open(tmp_path)
    with SessionStore.create(tmp_path, {"serial": "X"}) as store:
        assert store.metadata["serial"] == "X"
    with SessionStore.open(tmp_path) as store:
        assert store.metadata["status"] == "running"
    assert not (tmp_path / (SESSION_FILE + PARTIAL_SUFFIX)).exists()
