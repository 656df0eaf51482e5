"""`rig serve --store URL`: the lab's web page, read-only, on loopback unless told otherwise.

Beyond loopback the page is served only to users of a users file (`--users`, scrypt hashes, HTTP Basic
authentication) and only over TLS (`--tls-cert`, `--tls-key`), so that neither the lab's data nor a password
crosses the network in the clear; whoever asks, nothing but GET and HEAD is answered.
"""

from __future__ import annotations

import ipaddress
from pathlib import Path

import click

from rig.commands.lab import lab_errors, opened, store_option
from rig.exits import CommandError, Exit, busy_port


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@click.command()
@store_option
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to listen on (loopback by default; any other needs --users and --tls-cert/--tls-key).")
@click.option("--port", type=click.IntRange(0, 65535), default=8080, show_default=True)
@click.option("--users", "users_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Ask for a user of this file (NAME:scrypt hash lines; `rig lab user NAME --users FILE`).")
@click.option("--tls-cert", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Serve HTTPS with this certificate (PEM; with --tls-key).")
@click.option("--tls-key", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="The certificate's private key (PEM).")
def serve(store_url, host, port, users_file, tls_cert, tls_key):
    """Serve the lab's web page: sessions with live progress, reports, unit histories, rig comparison."""
    import errno
    import logging
    import socket
    import ssl

    if (tls_cert is None) != (tls_key is None):
        raise CommandError("--tls-cert and --tls-key go together", Exit.BAD_INPUT)
    if not is_loopback(host) and (users_file is None or tls_cert is None):
        raise CommandError(f"--host {host}: beyond loopback the page shows the lab's data to the network; serve it "
                           "there only with --users FILE (who may see it) and --tls-cert/--tls-key (so no password "
                           "or data crosses in the clear): docs/guides/lab-setup.md", Exit.BAD_INPUT)
    with lab_errors():
        import uvicorn

        from rig.lab.web.app import create_app
        from rig.lab.web.auth import ReadOnlyAuth, read_users

        users = read_users(users_file) if users_file is not None else None
        if tls_cert is not None:
            try:
                ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(tls_cert, tls_key)
            except (ssl.SSLError, OSError) as exc:
                raise CommandError(f"--tls-cert {tls_cert} / --tls-key {tls_key}: not a usable certificate and key "
                                   f"({getattr(exc, 'strerror', None) or exc})", Exit.BAD_INPUT) from None
        store = opened(store_url)
    try:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((host, port))
        except socket.gaierror as exc:
            sock.close()
            raise CommandError(f"--host {host}: {exc.strerror}", Exit.BAD_INPUT) from None
        except OSError as exc:
            sock.close()
            if exc.errno == errno.EADDRINUSE:
                raise CommandError(f"{host}:{port}: {busy_port(host, port)}: choose another --port",
                                   Exit.BUSY) from None
            raise CommandError(f"{host}:{port} cannot be used ({exc.strerror})", Exit.BAD_INPUT) from None
        scheme = "https" if tls_cert is not None else "http"
        who = f"users of {users_file}" if users is not None else "anyone on this machine"
        click.echo(f"serving {store.describe()} on {scheme}://{host}:{sock.getsockname()[1]}/ (read-only, to {who}; "
                   "Ctrl-C stops)", err=True)
        logging.getLogger("uvicorn.error").setLevel(logging.WARNING)
        config = uvicorn.Config(ReadOnlyAuth(create_app(store), users), log_level="warning", access_log=False,
                                lifespan="off", ssl_certfile=str(tls_cert) if tls_cert else None,
                                ssl_keyfile=str(tls_key) if tls_key else None)
        uvicorn.Server(config).run(sockets=[sock])     # on SIGINT/SIGTERM: shuts down, then raises it again
    finally:
        store.close()
