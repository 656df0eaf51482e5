"""`rig serve` beyond loopback: only with users (scrypt hashes in a file) over TLS, and read-only whoever asks."""

from __future__ import annotations

import base64
import ssl
import subprocess
import time
import urllib.error
import urllib.request

from .conftest import RIG, make_archive, no_traceback, rig
from .pgserver import free_port


def _certificate(folder):
    cert, key = folder / "cert.pem", folder / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=rig lab",
                    "-addext", "subjectAltName=IP:127.0.0.1", "-keyout", str(key), "-out", str(cert)],
                   check=True, capture_output=True)
    return cert, key


def _get(url, context, auth=None, method="GET"):
    request = urllib.request.Request(url, method=method)
    if auth:
        request.add_header("Authorization", "Basic " + base64.b64encode(auth.encode()).decode())
    try:
        with urllib.request.urlopen(request, timeout=20, context=context) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.read()


def test_beyond_loopback_the_page_needs_users_and_tls(tmp_path):
    make_archive(tmp_path / "store", [dict(unit="W-1", rig="r", start_utc="2026-05-02T08:00:00.000Z")])
    refused = rig("serve", "--store", tmp_path / "store", "--host", "0.0.0.0", "--port", free_port(), timeout=30)
    no_traceback(refused)
    assert refused.returncode == 2 and "--users" in refused.stderr and "--tls-cert" in refused.stderr

    users = tmp_path / "users"
    added = rig("lab", "user", "alice", "--users", users, "--password-stdin", input="correct horse battery\n")
    assert added.returncode == 0, added.stderr
    assert "correct horse" not in users.read_text() and users.read_text().startswith("alice:scrypt:")
    assert users.stat().st_mode & 0o077 == 0
    short = rig("lab", "user", "bob", "--users", users, "--password-stdin", input="short\n")
    assert short.returncode == 2 and "12 characters" in short.stderr

    cert, key = _certificate(tmp_path)
    port = free_port()
    proc = subprocess.Popen([*RIG, "serve", "--store", tmp_path / "store", "--host", "0.0.0.0", "--port", str(port),
                             "--users", users, "--tls-cert", cert, "--tls-key", key],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        context = ssl.create_default_context(cafile=str(cert))
        base = f"https://127.0.0.1:{port}"
        deadline = time.monotonic() + 30
        while True:
            try:
                status, _ = _get(base + "/units", context)
                break
            except (urllib.error.URLError, ConnectionError):
                assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
                time.sleep(0.2)
        assert status == 401
        assert _get(base + "/units", context, "alice:wrong password!")[0] == 401
        assert _get(base + "/units", context, "mallory:correct horse battery")[0] == 401
        status, body = _get(base + "/units", context, "alice:correct horse battery")
        assert status == 200 and b"W-1" in body
        assert _get(base + "/units", context, "alice:correct horse battery", method="POST")[0] == 405
        assert _get(base + "/units", context, method="DELETE")[0] == 405
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/units", timeout=10)
            plain = True
        except (urllib.error.URLError, ConnectionError):
            plain = False
        assert not plain                                             # no page in the clear
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=20)
    assert "Traceback" not in err and "correct horse" not in err
