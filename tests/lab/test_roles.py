"""Least privilege on the real server: the roles of `rig lab migrate` (and the SQL of `rig lab roles --sql`)
let a rig insert its own sessions and nothing else, readers read, and the owner migrate; credentials come
from libpq's password and service files."""

from __future__ import annotations

import subprocess

import psycopg
import pytest

from .conftest import make_archive, no_traceback, rig
from .pgserver import pg_bin


@pytest.fixture
def lab_db(pg_server, pg_url, tmp_path, monkeypatch):
    """A database migrated by its owner with two rig logins and a reader; their passwords in a password file
    and a service for rig r1 in a service file."""
    db = pg_url.rsplit("/", 1)[1]
    done = rig("lab", "migrate", "--store", pg_url, "--rig", "r1=rig_r1", "--rig", "r2=rig_r2",
               "--reader", "lab_page")
    assert done.returncode == 0, done.stderr
    passwords = {"rig_r1": "r1-password-long", "rig_r2": "r2-password-long", "lab_page": "page-password-long"}
    lines = []
    for login, password in passwords.items():
        pg_server.sql(f"ALTER ROLE {login} PASSWORD '{password}'")
        lines.append(f"127.0.0.1:{pg_server.port}:{db}:{login}:{password}")
    passfile = tmp_path / "pgpass"
    passfile.write_text("\n".join(lines) + "\n")
    passfile.chmod(0o600)
    services = tmp_path / "pg_service.conf"
    services.write_text(f"[lab-r1]\nhost=127.0.0.1\nport={pg_server.port}\ndbname={db}\nuser=rig_r1\n")
    monkeypatch.setenv("PGPASSFILE", str(passfile))
    monkeypatch.setenv("PGSERVICEFILE", str(services))
    url = lambda login: f"postgresql://{login}@127.0.0.1:{pg_server.port}/{db}"      # noqa: E731
    return url, pg_url


def test_a_rig_inserts_its_own_sessions_and_nothing_else(tmp_path, lab_db):
    url, admin = lab_db
    mine, theirs, forged = make_archive(tmp_path, [
        dict(unit="U-R1", rig="r1", name="mine", start_utc="2026-04-01T09:00:00.000Z"),
        dict(unit="U-R2", rig="r2", name="theirs", start_utc="2026-04-01T09:00:00.000Z"),
        dict(unit="U-R3", rig="r2", name="forged", start_utc="2026-04-02T09:00:00.000Z")])
    pushed = rig("push", mine, "--store", "postgresql://?service=lab-r1")          # the service file's login
    assert pushed.returncode == 0 and "pushed 12 holds" in pushed.stdout, pushed.stderr
    assert rig("push", theirs, "--store", url("rig_r2")).returncode == 0
    refused = rig("push", forged, "--store", url("rig_r1"))                         # r2's session, r1's login
    no_traceback(refused)
    assert refused.returncode == 2 and "row-level security" in refused.stderr, refused.stderr
    with psycopg.connect(admin) as conn:
        assert conn.execute("SELECT count(*) FROM sessions WHERE name = 'forged'").fetchone()[0] == 0
        before = conn.execute("SELECT s.name, s.status, s.holds, (SELECT count(*) FROM segments g WHERE "
                              "g.session_id = s.id) FROM sessions s ORDER BY s.name").fetchall()
        theirs_id = conn.execute("SELECT id FROM sessions WHERE name = 'theirs'").fetchone()[0]
    with psycopg.connect(url("rig_r1"), autocommit=True) as conn:
        hidden = conn.execute("UPDATE sessions SET status = 'rejected' WHERE name = 'theirs'")
        assert hidden.rowcount == 0                                                  # not its row to change
        assert conn.execute("SELECT count(*) FROM segments WHERE session_id = %s", (theirs_id,)).fetchone()[0] == 0
        assert conn.execute("SELECT count(*) FROM sessions").fetchone()[0] == 2       # summaries: for the claim
        for statement in ("DELETE FROM sessions WHERE name = 'theirs'", "DELETE FROM segments",
                          "UPDATE segments SET digest = 'x'", "UPDATE sessions SET key = gen_random_uuid()",
                          "UPDATE sessions SET rig_id = (SELECT id FROM rigs WHERE name = 'r2')",
                          "TRUNCATE samples", "SELECT count(*) FROM samples", "DROP TABLE events", "CREATE TABLE mine (x int)",
                          "INSERT INTO results (session_id, kind, run, ok, document) SELECT id, 'x', 'x', true, "
                          "'{}' FROM sessions", "UPDATE rig_logins SET rig = 'r2'"):
            with pytest.raises(psycopg.errors.InsufficientPrivilege):
                conn.execute(statement)
        with pytest.raises(psycopg.errors.InsufficientPrivilege):                   # a row into r2's session
            conn.execute("INSERT INTO events (session_id, seq, t, kind, message, written_utc) "
                         "VALUES (%s, 999, 0, 'note', 'not mine', now())", (theirs_id,))
    with psycopg.connect(admin) as conn:
        assert conn.execute("SELECT s.name, s.status, s.holds, (SELECT count(*) FROM segments g WHERE "
                            "g.session_id = s.id) FROM sessions s ORDER BY s.name").fetchall() == before


def test_readers_read_and_cannot_write(tmp_path, lab_db):
    url, _ = lab_db
    folder, = make_archive(tmp_path, [dict(unit="U-R1", rig="r1", start_utc="2026-04-03T09:00:00.000Z")])
    assert rig("push", folder, "--store", url("rig_r1")).returncode == 0
    units = rig("units", "--store", url("lab_page"))
    assert units.returncode == 0 and "U-R1" in units.stdout, units.stderr
    refused = rig("push", folder, "--store", url("lab_page"))
    no_traceback(refused)
    assert refused.returncode == 2 and "may not" in refused.stderr, refused.stderr


def test_a_rig_cannot_make_the_tables_the_owner_does(tmp_path, pg_server, lab_db):
    url, _ = lab_db
    fresh = pg_server.createdb("lab_roles_fresh")
    db = fresh.rsplit("/", 1)[1]
    folder, = make_archive(tmp_path, [dict(unit="U-R1", rig="r1", start_utc="2026-04-04T09:00:00.000Z")])
    pg_server.sql(f"GRANT CONNECT ON DATABASE {db} TO lab_rig")
    passfile = tmp_path / "pgpass"
    passfile.write_text(passfile.read_text() + f"127.0.0.1:{pg_server.port}:{db}:rig_r1:r1-password-long\n")
    done = rig("push", folder, "--store", f"postgresql://rig_r1@127.0.0.1:{pg_server.port}/{db}")
    no_traceback(done)
    assert done.returncode == 2 and "rig lab migrate" in done.stderr, done.stderr


def test_the_printed_sql_runs_twice_in_psql_and_is_the_same_rules(tmp_path, pg_server):
    fresh = pg_server.createdb("lab_roles_psql")
    sql = rig("lab", "roles", "--sql", "--rig", "r9=rig_r9", "--reader", "lab_page9")
    assert sql.returncode == 0 and "ROW LEVEL SECURITY" in sql.stdout
    script = tmp_path / "roles.sql"
    script.write_text(sql.stdout)
    for _ in range(2):
        done = subprocess.run([str(pg_bin() / "psql"), "-X", "-v", "ON_ERROR_STOP=1", "-1", "-q", "-f", str(script),
                               fresh], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    policies = pg_server.sql("SELECT tablename, policyname FROM pg_policies ORDER BY 1, 2", db=fresh.rsplit("/", 1)[1])
    assert ("samples", "rig_insert") in policies and ("sessions", "rig_update") in policies
    assert pg_server.sql("SELECT rig FROM rig_logins WHERE login = 'rig_r9'", db=fresh.rsplit("/", 1)[1]) == [("r9",)]


def test_tls_is_required_and_verified_and_a_refused_plain_connection_is_not_retried(tmp_path, monkeypatch):
    """A server that takes the lab's logins over TLS only: a rig with sslmode=verify-full and the lab's CA
    pushes; one without TLS is refused by pg_hba.conf once, in one line (exit 2), never retried."""
    import os
    import pwd

    from .pgserver import PgServer
    from .proxy import CountingProxy

    server = PgServer()
    try:
        cert, key = server.root / "server.crt", server.root / "server.key"
        subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj",
                        "/CN=127.0.0.1", "-addext", "subjectAltName=IP:127.0.0.1", "-keyout", str(key), "-out",
                        str(cert)], check=True, capture_output=True)
        key.chmod(0o600)
        if os.geteuid() == 0:
            user = pwd.getpwnam("postgres")
            for path in (cert, key):
                os.chown(path, user.pw_uid, user.pw_gid)
        server.write_hba("hostssl all rig 127.0.0.1/32 trust\nhostssl all all 127.0.0.1/32 scram-sha-256\n"
                         "hostnossl all all 127.0.0.1/32 reject\n")
        server.start("ssl=on", f"ssl_cert_file={cert}", f"ssl_key_file={key}")
        admin = server.createdb("lab") + f"?sslmode=verify-full&sslrootcert={cert}"
        assert rig("lab", "migrate", "--store", admin, "--rig", "r1=rig_r1").returncode == 0
        server.sql("ALTER ROLE rig_r1 PASSWORD 'r1-password-long'")
        passfile = tmp_path / "pgpass"
        passfile.write_text(f"127.0.0.1:*:lab:rig_r1:r1-password-long\n")
        passfile.chmod(0o600)
        monkeypatch.setenv("PGPASSFILE", str(passfile))
        folder, = make_archive(tmp_path, [dict(unit="U-TLS", rig="r1", start_utc="2026-04-05T09:00:00.000Z")])
        proxy = CountingProxy(server.port)
        try:
            plain = rig("push", folder, "--store", proxy.url("lab", "rig_r1") + "?sslmode=disable", "--follow")
            no_traceback(plain)
            assert plain.returncode == 2 and "no encryption" in plain.stderr, plain.stderr
            assert len(proxy.attempts) == 1
        finally:
            proxy.close()
        verified = rig("push", folder, "--store",
                       f"postgresql://rig_r1@127.0.0.1:{server.port}/lab?sslmode=verify-full&sslrootcert={cert}")
        assert verified.returncode == 0 and "pushed 12 holds" in verified.stdout, verified.stderr
        with psycopg.connect(admin) as conn:
            assert conn.execute("SELECT count(*) FROM sessions").fetchone()[0] == 1
    finally:
        server.destroy()
