"""`rig serve --store URL`: the lab's web page, read-only, on loopback unless told otherwise."""

from __future__ import annotations

import click

from rig.commands.lab import lab_errors, opened, store_option
from rig.exits import CommandError, Exit


@click.command()
@store_option
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to listen on (loopback by default; 0.0.0.0 shows the page to the whole network).")
@click.option("--port", type=click.IntRange(0, 65535), default=8080, show_default=True)
def serve(store_url, host, port):
    """Serve the lab's web page: sessions with live progress, reports, unit histories, rig comparison."""
    import errno
    import logging
    import socket

    with lab_errors():
        import uvicorn

        from rig.lab.web.app import create_app

        store = opened(store_url)
    try:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((host, port))
        except OSError as exc:
            sock.close()
            why = "is in use" if exc.errno == errno.EADDRINUSE else f"cannot be used ({exc.strerror})"
            raise CommandError(f"{host}:{port} {why}: choose another --port", Exit.BAD_INPUT) from None
        except socket.gaierror as exc:
            sock.close()
            raise CommandError(f"--host {host}: {exc.strerror}", Exit.BAD_INPUT) from None
        click.echo(f"serving {store.describe()} on http://{host}:{sock.getsockname()[1]}/ (read-only; Ctrl-C stops)",
                   err=True)
        logging.getLogger("uvicorn.error").setLevel(logging.WARNING)
        config = uvicorn.Config(create_app(store), log_level="warning", access_log=False, lifespan="off")
        uvicorn.Server(config).run(sockets=[sock])     # on SIGINT/SIGTERM: shuts down, then raises it again
    finally:
        store.close()
