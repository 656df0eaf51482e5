"""Nothing corrupt enters the store: each kind of damage a copied or edited session folder can carry is
refused by `rig push` with the file and the reason (exit 2), nothing of that session is stored, and the
folder is left as it was. The folder store and the questions name what they skip rather than hide it."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import psycopg
import pytest

from rig.store import arrays

from .conftest import make_archive, no_traceback, rig


def _contents(folder) -> dict:
    """The folder's files, without SQLite's shared-memory index (a reader's, not the session's)."""
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file() and not p.name.endswith("-shm")}


def _db(folder):
    return sqlite3.connect(folder / "session.sqlite")


def truncated_calibration(folder):
    text = (folder / "calibration.json").read_text()
    (folder / "calibration.json").write_text(text[: len(text) // 2])
    return "calibration.json", "not valid JSON"


def calibration_breaking_its_format(folder):
    doc = json.loads((folder / "calibration.json").read_text())
    sensor = next(iter(doc["sensors"]))
    doc["sensors"][sensor]["H"] = [[-v for v in row] for row in doc["sensors"][sensor]["H"]]   # det(H) < 0
    (folder / "calibration.json").write_text(json.dumps(doc))
    return "calibration.json", "det(H)"


def truncated_session_file(folder):
    path = folder / "session.sqlite"
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    return "session.sqlite", "malformed"


def foreign_sqlite_file(folder):
    path = folder / "session.sqlite"
    path.unlink()
    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE notes (id INTEGER PRIMARY KEY, text TEXT)")
    return "session.sqlite", "not a rig session"


def text_in_place_of_the_session_file(folder):
    (folder / "session.sqlite").write_text("this is not a database\n" * 200)
    return "session.sqlite", "not a readable session file"


def a_damaged_page(folder):
    with _db(folder) as db:
        root = db.execute("SELECT rootpage FROM sqlite_master WHERE name = 'sqlite_autoindex_array_1'").fetchone()[0]
        size = db.execute("PRAGMA page_size").fetchone()[0]
    with open(folder / "session.sqlite", "r+b") as f:          # the index's page: its cells overwritten
        f.seek((root - 1) * size + 12)
        f.write(bytes(range(256)) * 4)
    return "session.sqlite", "integrity check"


def a_table_of_the_layout_missing(folder):
    with _db(folder) as db:
        db.execute("DROP TABLE hold_stat")
    return "session.sqlite", "table 'hold_stat'"


def an_array_cut_short(folder):
    with _db(folder) as db:
        db.execute("UPDATE array SET data = substr(data, 1, 100) WHERE segment_id = 4 AND name = 'raw:accel'")
    return "segment 4", "does not decode"


def a_time_that_is_not_finite(folder):
    with _db(folder) as db:
        dtype, shape, blob = db.execute("SELECT dtype, shape, data FROM array WHERE segment_id = 6 AND name = 't'"
                                        ).fetchone()
        t = arrays.decode(dtype, shape, blob).copy()
        t[3] = np.nan
        db.execute("UPDATE array SET data = ? WHERE segment_id = 6 AND name = 't'", (arrays.encode(t)[2],))
    return "segment 6", "t row 3 is not finite"


def a_span_that_is_not_its_samples(folder):
    with _db(folder) as db:
        db.execute("UPDATE segment SET t_end = t_end + 5 WHERE id = 8")
    return "segment 8", "span"


def hold_statistics_that_are_not_the_samples(folder):
    with _db(folder) as db:
        db.execute("UPDATE hold_stat SET mean = mean + 0.01 WHERE segment_id = 11 AND channel LIKE '%x'")
    return "segment 11", "hold statistics"


def metadata_that_is_not_json(folder):
    with _db(folder) as db:
        db.execute("INSERT INTO metadata (key, value, written_utc) VALUES ('operator', '{\"half', "
                   "'2026-03-12T09:30:00.000Z')")
    return "metadata row", "not JSON"


def an_event_without_a_time(folder):
    with _db(folder) as db:
        db.execute("UPDATE event SET written_utc = 'yesterday' WHERE id = (SELECT min(id) FROM event)")
    return "event", "not a time"


def a_truncated_plot(folder):
    png = b"\x89PNG\r\n\x1a\n" + b"\0" * 64 + b"IEND\xaeB`\x82"
    (folder / "residuals.png").write_bytes(png[:40])
    return "residuals.png", "not a whole PNG"


CORRUPTIONS = [truncated_calibration, calibration_breaking_its_format, truncated_session_file, foreign_sqlite_file,
               text_in_place_of_the_session_file, a_damaged_page, a_table_of_the_layout_missing, an_array_cut_short,
               a_time_that_is_not_finite, a_span_that_is_not_its_samples, hold_statistics_that_are_not_the_samples,
               metadata_that_is_not_json, an_event_without_a_time, a_truncated_plot]


@pytest.mark.parametrize("corrupt", CORRUPTIONS, ids=lambda f: f.__name__)
def test_a_corrupt_folder_is_refused_at_push_naming_the_file_and_the_reason(tmp_path, pg_url, corrupt):
    folder, sound = make_archive(tmp_path, [dict(unit="U-C", rig="r1", start_utc="2026-03-12T09:00:00.000Z"),
                                            dict(unit="U-C", rig="r1", start_utc="2026-03-13T09:00:00.000Z")])
    with _db(folder) as db:
        db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    where, why = corrupt(folder)
    before = _contents(folder)
    done = rig("push", folder, "--store", pg_url)
    no_traceback(done)
    assert done.returncode == 2, done.stdout + done.stderr
    assert where in done.stderr and why in done.stderr, done.stderr
    assert "pushed" not in done.stdout
    assert _contents(folder) == before
    with psycopg.connect(pg_url) as conn:
        stored = conn.execute("SELECT to_regclass('sessions') IS NOT NULL").fetchone()[0] and \
            conn.execute("SELECT count(*) FROM sessions WHERE name = %s", (folder.name,)).fetchone()[0]
    assert not stored
    good = rig("push", sound, "--store", pg_url)                 # the store itself is unharmed
    assert good.returncode == 0 and "pushed 12 holds" in good.stdout, good.stderr


def test_every_question_of_a_folder_store_names_what_it_skips(tmp_path, serve):
    folders = make_archive(tmp_path, [dict(unit="U-F", rig="r1", name=f"f{k}", start_utc=f"2026-03-1{k}T09:00:00.000Z")
                                      for k in range(5)])
    for folder in folders:
        with _db(folder) as db:
            db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    truncated_session_file(folders[1])
    foreign_sqlite_file(folders[2])
    truncated_calibration(folders[3])
    named = [str(folders[1]), str(folders[2]), str(folders[3] / "calibration.json")]
    for args in (["units"], ["history", "U-F"], ["pass-fail"], ["compare-rigs", "--unit", "U-F"]):
        done = rig(*args, "--store", tmp_path, "--json", tmp_path / "answer.json")
        no_traceback(done)
        assert done.returncode == 0, (args, done.stderr)
        warnings = [line for line in done.stderr.splitlines() if line.startswith("warning: skipped")]
        assert all(any(line.startswith(f"warning: skipped {n}") for line in warnings) for n in named), (args, warnings)
        answer = json.loads((tmp_path / "answer.json").read_text())
        assert sorted(s["what"] for s in answer["skipped"]) == sorted(named)
    history = json.loads((tmp_path / "answer.json").read_text())
    units = rig("units", "--store", tmp_path)
    assert "U-F" in units.stdout and " 2 calibrations     3 sessions" in units.stdout, units.stdout
    page = serve(str(tmp_path))
    status, body = page.get("/units")
    assert status == 200
    text = body.decode()
    assert "3 left out of this page" in text and all(n in text for n in named)
    assert history["rigs"][0]["sessions"] == 2


def test_a_corrupt_calibration_stored_before_pushes_were_checked_is_left_out_and_named(tmp_path, pg_url):
    first, second = make_archive(tmp_path, [dict(unit="U-G", rig="r1", start_utc="2026-03-14T09:00:00.000Z"),
                                            dict(unit="U-G", rig="r1", start_utc="2026-03-15T09:00:00.000Z")])
    for folder in (first, second):
        assert rig("push", folder, "--store", pg_url).returncode == 0
    with psycopg.connect(pg_url, autocommit=True) as conn:        # as an older rig's push had let in
        conn.execute("INSERT INTO calibrations (session_id, source, digest, document) SELECT id, 'rig', 'x', "
                     "'{\"schema\": \"rig-calibration/1\", \"sens' FROM sessions WHERE name = %s", (second.name,))
    done = rig("history", "U-G", "--store", pg_url)
    no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert "warning: skipped" in done.stderr and f"session {second.name}" in done.stderr and "not valid JSON" in \
        done.stderr
    assert first.name in done.stdout and second.name not in done.stdout
    assert rig("compare-rigs", "--unit", "U-G", "--store", pg_url).returncode == 0
