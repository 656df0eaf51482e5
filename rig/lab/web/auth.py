"""Who may see the lab's page when it is served beyond loopback: users from a file of scrypt hashes, asked by
HTTP Basic authentication (over TLS: `rig serve --tls-cert/--tls-key`), and nothing but reading.

The users file holds one `NAME:scrypt:N:r:p:SALT:HASH` line per user (hex salt and hash; `rig lab user NAME
--users FILE` adds one, asking for the password): a password is never stored, and a stolen file costs an
attacker scrypt's work per guess (RFC 7914; N = 2^15, r = 8, p = 1 by default). Blank lines and `#` comments
are allowed. Every request but GET and HEAD is refused (405), whoever asks.
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import os
import threading
from pathlib import Path

from rig.lab.errors import StoreInputError

SCRYPT_N, SCRYPT_R, SCRYPT_P = 2 ** 15, 8, 1
REALM = "rig lab"
READ_METHODS = ("GET", "HEAD")


def hash_password(password: str, *, n: int = SCRYPT_N, r: int = SCRYPT_R, p: int = SCRYPT_P) -> str:
    salt = os.urandom(16)
    digest = hashlib.scrypt(password.encode(), salt=salt, n=n, r=r, p=p, maxmem=_maxmem(n, r), dklen=32)
    return f"scrypt:{n}:{r}:{p}:{salt.hex()}:{digest.hex()}"


def verify(password: str, stored: str) -> bool:
    try:
        kind, n, r, p, salt, digest = stored.split(":")
        n, r, p = int(n), int(r), int(p)
        if kind != "scrypt":
            return False
        mine = hashlib.scrypt(password.encode(), salt=bytes.fromhex(salt), n=n, r=r, p=p, maxmem=_maxmem(n, r),
                              dklen=len(bytes.fromhex(digest)))
    except (ValueError, OverflowError):
        return False
    return hmac.compare_digest(mine, bytes.fromhex(digest))


def read_users(path: str | Path) -> dict[str, str]:
    """name -> stored hash; a line that is not `NAME:scrypt:...` is refused, naming its line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise StoreInputError(f"{path}: cannot be read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise StoreInputError(f"{path}: not UTF-8 text") from None
    users = {}
    for number, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, sep, stored = line.partition(":")
        fields = stored.split(":")
        if not sep or not name or len(fields) != 6 or fields[0] != "scrypt":
            raise StoreInputError(f"{path}, line {number}: not NAME:scrypt:N:r:p:SALT:HASH (add users with "
                                  "`rig lab user NAME --users FILE`; a password is never written in clear)")
        users[name] = stored
    if not users:
        raise StoreInputError(f"{path}: no users (add one with `rig lab user NAME --users {path}`)")
    return users


def add_user(path: str | Path, name: str, password: str) -> None:
    """Add or replace `name` in the users file (made with mode 600 if new)."""
    if not name or ":" in name or any(c.isspace() for c in name):
        raise StoreInputError(f"user name {name!r}: no colon or space")
    if len(password) < 12:
        raise StoreInputError("the password must have at least 12 characters")
    path = Path(path)
    lines = path.read_text(encoding="utf-8").splitlines() if path.exists() else []
    lines = [line for line in lines if line.partition(":")[0].strip() != name]
    lines.append(f"{name}:{hash_password(password)}")
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")


class ReadOnlyAuth:
    """ASGI middleware: GET and HEAD only; with `users`, each request must carry one of them (Basic)."""

    def __init__(self, app, users: dict[str, str] | None) -> None:
        self.app, self.users = app, users
        self._known: dict[bytes, str] = {}          # a header already verified -> its user (scrypt once)
        self._lock = threading.Lock()

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        if scope["method"] not in READ_METHODS:
            await _answer(send, 405, b"the lab's page is read-only\n", [(b"allow", b"GET, HEAD")])
            return
        if self.users is not None and not self._allowed(dict(scope["headers"]).get(b"authorization", b"")):
            await _answer(send, 401, b"authentication required\n",
                          [(b"www-authenticate", f'Basic realm="{REALM}", charset="UTF-8"'.encode())])
            return
        await self.app(scope, receive, send)

    def _allowed(self, header: bytes) -> bool:
        key = hashlib.sha256(header).digest()
        with self._lock:
            if key in self._known:
                return True
        scheme, _, value = header.partition(b" ")
        if scheme.lower() != b"basic":
            return False
        try:
            name, sep, password = base64.b64decode(value, validate=True).decode("utf-8").partition(":")
        except (ValueError, UnicodeDecodeError):
            return False
        stored = self.users.get(name)
        if not sep or stored is None or not verify(password, stored):
            return False
        with self._lock:
            if len(self._known) > 1000:
                self._known.clear()
            self._known[key] = name
        return True


async def _answer(send, status: int, body: bytes, headers: list[tuple[bytes, bytes]]) -> None:
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"text/plain; charset=utf-8"),
                            (b"content-length", str(len(body)).encode()), *headers]})
    await send({"type": "http.response.body", "body": body})


def _maxmem(n: int, r: int) -> int:
    return 128 * r * n + (1 << 20) * 4
