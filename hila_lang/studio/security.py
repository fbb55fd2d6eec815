"""The studio's guard: a token on every request, loopback Host/Origin only, files only inside FOLDER.

docs/design.md §6: ``hila studio`` serves 127.0.0.1 only, like Jupyter; a web page elsewhere must not
be able to drive it (no token), nor reach it through a name that resolves to 127.0.0.1 (DNS
rebinding: the Host header is not ours), nor open its websocket from another origin.

:class:`Guard` is plain ASGI middleware (HTTP and websocket alike).  The token arrives as
``?token=`` in the URL the command prints; the page's first load sets a cookie (HttpOnly,
SameSite=Strict, named with the port, since cookies are not kept apart by port) so later
requests and websockets carry it without the token in every URL.
"""

from __future__ import annotations

import os
import secrets
from http.cookies import SimpleCookie
from pathlib import Path, PurePosixPath, PureWindowsPath
from urllib.parse import parse_qs

from ..core.errors import InputError

#: largest request body accepted (an uploaded picture, CSV, recording or program), bytes.
#: 20 MB: an A4 photograph from a phone (3-8 MB) or a long recording with eye images fits.
MAX_UPLOAD = 20 * 1024 * 1024

LOOPBACK_NAMES = ("127.0.0.1", "localhost")


def new_token() -> str:
    """A fresh random token (URL-safe, 32 bytes of entropy) for one start of the studio."""
    return secrets.token_urlsafe(32)


def cookie_name(port: int) -> str:
    return f"hila_studio_{port}"


def _header(scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", ()):
        if key == name:
            return value.decode("latin-1")
    return None


def refusal(scope, token: str, port: int) -> str | None:
    """Why a request (an ASGI ``scope``) is refused, or None when it may go on.

    Checked in this order: the Host header (exactly 127.0.0.1:PORT or localhost:PORT), the
    Origin header when there is one (http://127.0.0.1:PORT or http://localhost:PORT; a websocket
    needs one), then the token (the ``token`` query parameter or the studio's cookie).
    """
    allowed_hosts = {f"{name}:{port}" for name in LOOPBACK_NAMES}
    host = _header(scope, b"host")
    if host not in allowed_hosts:
        return (f"refused: Host {host!r} is not this studio's address (127.0.0.1:{port}); "
                "open the URL 'hila studio' printed")
    origin = _header(scope, b"origin")
    if origin is not None and origin not in {f"http://{h}" for h in allowed_hosts}:
        return f"refused: a request from the page at {origin!r}; only the studio's own page may call it"
    if scope["type"] == "websocket" and origin is None:
        return "refused: a websocket without an Origin header"
    given = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [None])[0]
    if given is None:
        cookie = SimpleCookie()
        try:
            cookie.load(_header(scope, b"cookie") or "")
        except Exception:  # noqa: BLE001 - a malformed cookie header is just no token
            pass
        morsel = cookie.get(cookie_name(port))
        given = morsel.value if morsel is not None else None
    if given is None:
        return "refused: no token; open the URL 'hila studio' printed (it ends in ?token=...)"
    if not secrets.compare_digest(given.encode(), token.encode()):
        return "refused: wrong token; open the URL this start of 'hila studio' printed"
    return None


class Guard:
    """ASGI middleware: :func:`refusal` for every HTTP request and websocket; a refused HTTP
    request gets 403 and the reason as text, a refused websocket is closed before it opens."""

    def __init__(self, app, token: str, port: int) -> None:
        self.app, self.token, self.port = app, token, port

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        why = refusal(scope, self.token, self.port)
        if why is None:
            return await self.app(scope, receive, send)
        if scope["type"] == "websocket":
            await receive()  # websocket.connect
            await send({"type": "websocket.close", "code": 4403, "reason": why[:120]})
            return
        body = (why + "\n").encode()
        await send({"type": "http.response.start", "status": 403,
                    "headers": [(b"content-type", b"text/plain; charset=utf-8"),
                                (b"content-length", str(len(body)).encode())]})
        await send({"type": "http.response.body", "body": body})


def inside(folder: Path, name: str) -> Path:
    """``name`` (a path relative to ``folder``, '/'-separated) as a path inside ``folder``.

    Refused with an :class:`InputError` that says why: an empty name, an absolute path, a ``..``
    part, or a path that leaves ``folder`` through a symbolic link.
    """
    root = folder.resolve()
    if not name or not name.strip():
        raise InputError("refused: no file named")
    if "\x00" in name:
        raise InputError("refused: a file name with a NUL character")
    if PurePosixPath(name).is_absolute() or PureWindowsPath(name).is_absolute() or PureWindowsPath(name).drive:
        raise InputError(f"refused: {name!r} is an absolute path; the studio reads and writes only inside "
                         f"{root}, so name files relative to it")
    parts = PurePosixPath(name.replace("\\", "/")).parts
    if ".." in parts:
        raise InputError(f"refused: {name!r} goes up a folder ('..'); the studio reads and writes only inside {root}")
    candidate = root.joinpath(*parts)
    real = Path(os.path.realpath(candidate))
    if real != root and root not in real.parents:
        raise InputError(f"refused: {name!r} is a symbolic link that leads outside {root} (to {real})")
    return candidate
