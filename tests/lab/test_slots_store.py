"""A session of several slots in the lab's store: each slot stored as a session of its own unit (its serial, its
calibration, its verdict) that records the table it shared (the slots session's id, how many units, the table
time), pushed afterwards (`rig push SLOTS_FOLDER`) or mirrored while it runs (`rig calibrate --store`), and shown
by `rig history` and the web page of the unit and of its session."""

from __future__ import annotations

import json
from pathlib import Path

import psycopg
import pytest

from .conftest import no_traceback, rig

FOUR_SLOTS = Path(__file__).resolve().parents[2] / "rig" / "configs" / "four-slots.toml"


def short_four_slots(tmp_path: Path) -> Path:
    text = FOUR_SLOTS.read_text()
    assert "orientations = 20" in text and "hold_s = 5.0" in text
    path = tmp_path / "four.toml"
    path.write_text(text.replace("orientations = 20", "orientations = 9").replace("hold_s = 5.0", "hold_s = 1.0"))
    return path


def stored_sessions(url: str) -> dict[str, dict]:
    with psycopg.connect(url) as conn:
        rows = conn.execute("SELECT u.serial, s.status, s.verdict, c.document FROM sessions s "
                            "JOIN units u ON u.id = s.unit_id JOIN calibrations c ON c.session_id = s.id "
                            "WHERE c.source = 'rig'").fetchall()
    return {serial: {"status": status, "verdict": verdict, "calibration": json.loads(doc)}
            for serial, status, verdict, doc in rows}


def check_store(url: str, out: Path) -> dict:
    manifest = json.loads((out / "slots.json").read_text())
    stored = stored_sessions(url)
    serials = {s["serial"] for s in manifest["slots"]}
    assert set(stored) == serials, stored.keys()
    for slot in manifest["slots"]:
        local = json.loads((out / slot["folder"] / "calibration.json").read_text())
        one = stored[slot["serial"]]
        assert one["calibration"]["sensors"]["gyro"]["H"] == local["sensors"]["gyro"]["H"]
        assert one["verdict"] == manifest["ended"][slot["name"]]["verdict"]
        table = one["calibration"]["table"]
        assert table["session"] == manifest["id"]
        assert table["units"] == len(manifest["slots"])
        assert table["table_time_s"] == pytest.approx(manifest["table_time_s"], rel=1e-9)
    return manifest


def test_push_of_a_slots_folder_stores_one_session_per_unit_with_the_shared_table(tmp_path, pg_url, serve):
    out = tmp_path / "table"
    done = rig("calibrate", "--sim", "--config", short_four_slots(tmp_path), "--no-progress", "--seed", 5,
               "--out", out, timeout=600)
    no_traceback(done)
    assert done.returncode in (0, 1), done.stderr
    pushed = rig("push", out, "--store", pg_url)
    no_traceback(pushed)
    assert pushed.returncode == 0, pushed.stderr
    manifest = check_store(pg_url, out)
    again = rig("push", out, "--store", pg_url)
    assert again.returncode == 0 and again.stdout.count("up to date") == len(manifest["slots"]), again.stdout
    serial = manifest["slots"][1]["serial"]
    history = rig("history", serial, "--store", pg_url)
    no_traceback(history)
    assert history.returncode == 0, history.stderr
    assert (f"shared table with {len(manifest['slots'])} units, table time {manifest['table_time_s']:.0f} s"
            in history.stdout), history.stdout
    assert manifest["id"] in history.stdout
    served = serve(pg_url)
    line = f"shared table with {len(manifest['slots'])} units, table time {manifest['table_time_s']:.0f} s"
    status, body = served.get(f"/unit/{serial}")
    assert status == 200 and line in body.decode(), body[:2000]
    with psycopg.connect(pg_url) as conn:
        key = conn.execute("SELECT s.key::text FROM sessions s JOIN units u ON u.id = s.unit_id WHERE u.serial = %s",
                           (serial,)).fetchone()[0]
    status, body = served.get(f"/session/{key}")
    assert status == 200 and line in body.decode() and manifest["id"] in body.decode(), body[:2000]


def test_calibrate_with_store_mirrors_every_slot_as_its_own_session(tmp_path, pg_url):
    out = tmp_path / "table"
    done = rig("calibrate", "--sim", "--config", short_four_slots(tmp_path), "--no-progress", "--seed", 6,
               "--store", pg_url, "--out", out, timeout=600)
    no_traceback(done)
    assert done.returncode in (0, 1), done.stderr
    check_store(pg_url, out)
