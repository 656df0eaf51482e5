"""`rig calibrate --store URL` and `[store] url`: the session recorded locally and mirrored into the lab's
database as it runs; a database that is not there costs nothing recorded, and `rig push` finishes the job."""

from __future__ import annotations

import json

import psycopg

from .conftest import no_traceback, rig
from .pgserver import free_port
from .test_push import local_counts, stored_counts

FAST = ("--sim", "--seed", "3", "--time-scale", "50", "--orientations", "9", "--no-progress")


def test_a_session_run_with_store_lands_in_the_database_whole(tmp_path, pg_url):
    out = tmp_path / "unit-a"
    done = rig("calibrate", *FAST, "--store", pg_url, "--out", out, timeout=300)
    no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert (out / "calibration.json").exists()
    assert stored_counts(pg_url, out.name) == local_counts(out)


def test_the_store_from_the_toml_unreachable_then_pushed(tmp_path, pg_url):
    dead = f"postgresql://rig@127.0.0.1:{free_port()}/lab"
    toml = tmp_path / "rig.toml"
    toml.write_text(f'[schedule]\norientations = 9\n\n[store]\nurl = "{dead}"\nrig = "bench-7"\n')
    out = tmp_path / "unit-b"
    done = rig("calibrate", "--sim", "--seed", "4", "--time-scale", "50", "--no-progress", "--config", toml,
               "--out", out, timeout=300)
    no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert "rig push" in done.stderr and f"127.0.0.1:{dead.split(':')[-1].split('/')[0]}" in done.stderr
    pushed = rig("push", out, "--store", pg_url)
    no_traceback(pushed)
    assert pushed.returncode == 0, pushed.stderr
    assert stored_counts(pg_url, out.name) == local_counts(out)
    with psycopg.connect(pg_url) as conn:
        assert conn.execute("SELECT r.name FROM sessions s JOIN rigs r ON r.id = s.rig_id WHERE s.name = %s",
                            (out.name,)).fetchone() == ("bench-7",)


def test_a_folder_store_wants_the_session_inside_it(tmp_path):
    done = rig("calibrate", *FAST, "--store", tmp_path / "lab", "--out", tmp_path / "elsewhere")
    no_traceback(done)
    assert done.returncode == 2 and "is not inside it" in done.stderr
    assert not (tmp_path / "elsewhere").exists()


def test_repeatability_trials_go_to_the_store_of_its_configuration(tmp_path, pg_url):
    """Every trial is a session in the lab's store ([store] of the TOML), under the unit its seed is."""
    toml = tmp_path / "rig.toml"
    toml.write_text(f'[schedule]\norientations = 9\n\n[store]\nurl = "{pg_url}"\nrig = "bench-r"\n')
    out = tmp_path / "series"
    done = rig("repeatability", "--config", toml, "--sim", "--seed", "5", "--trials", "2", "--out", out, timeout=400)
    no_traceback(done)
    assert done.returncode == 0, done.stderr
    assert (out / "repeatability.md").exists()
    with psycopg.connect(pg_url) as conn:
        stored = conn.execute("SELECT s.name, u.serial, r.name FROM sessions s JOIN units u ON u.id = s.unit_id "
                              "JOIN rigs r ON r.id = s.rig_id ORDER BY s.name").fetchall()
    assert stored == [("trial-001", "SIM-0005", "bench-r"), ("trial-002", "SIM-0005", "bench-r")]
    for trial in ("trial-001", "trial-002"):
        assert stored_counts(pg_url, trial) == local_counts(out / trial)


def test_a_simulated_unit_is_named_by_its_seed_unless_the_toml_names_it(tmp_path):
    named = tmp_path / "named.toml"
    named.write_text('[unit]\nserial = "BENCH-UNIT"\n\n[schedule]\norientations = 9\n')
    for args, serial in (((), "SIM-0008"), (("--config", named), "BENCH-UNIT")):
        out = tmp_path / serial
        done = rig("calibrate", "--sim", "--seed", "8", "--orientations", "9", "--time-scale", "50", "--no-progress",
                   *args, "--out", out, timeout=300)
        no_traceback(done)
        assert done.returncode == 0, done.stderr
        assert json.loads((out / "calibration.json").read_text())["unit"]["serial"] == serial
