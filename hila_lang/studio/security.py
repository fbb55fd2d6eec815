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

import contextlib
import errno
import os
import secrets
import stat
from http.cookies import SimpleCookie
from pathlib import Path, PurePosixPath, PureWindowsPath
from urllib.parse import parse_qs

from ..core.errors import HilaError, InputError
from ..core.resources import shipped
from ..language.loader import TemplateLoader

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
    needs one), then the token (the ``token`` query parameter, the ``X-Hila-Token`` header, or
    the studio's cookie -- the cookie alone only for the page itself or a same-origin request:
    :func:`_cookie_only_refusal`).
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
        given = _header(scope, b"x-hila-token")
    by_cookie = given is None
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
    return _cookie_only_refusal(scope) if by_cookie else None


#: what the page itself loads by the cookie alone, from anywhere (it holds no data of the folder)
PAGE_PATHS = ("/", "/favicon.ico")


def _cookie_only_refusal(scope) -> str | None:
    """Why a request that carries the token only in the cookie is refused, or None.

    The cookie is sent with every request to 127.0.0.1, whichever port the page that makes it
    came from (SameSite does not separate ports, and an ``<img>`` sends no Origin).  So a request
    for data (anything but the page and its scripts) needs more: the token in the
    ``X-Hila-Token`` header (the page's fetch sets it) or the browser's ``Sec-Fetch-Site:
    same-origin`` (or ``none``: the person typed the address), which no other page can send."""
    path = scope.get("path", "")
    if scope["type"] == "websocket" or path in PAGE_PATHS or path.startswith("/static/"):
        return None
    site = _header(scope, b"sec-fetch-site")
    if site in ("same-origin", "none"):
        return None
    return ("refused: a request for the studio's data from another page "
            f"(Sec-Fetch-Site: {site or 'not sent'}, no X-Hila-Token); only the studio's own page may read it")


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


def _checked_parts(root: Path, name: str) -> tuple[str, ...]:
    """``name``'s parts, refused with an :class:`InputError` that says why: an empty name, a NUL,
    an absolute path or a ``..`` part (nothing on the disk is looked at)."""
    if not isinstance(name, str) or not name or not name.strip():
        raise InputError("refused: no file named")
    if "\x00" in name:
        raise InputError("refused: a file name with a NUL character")
    if PurePosixPath(name).is_absolute() or PureWindowsPath(name).is_absolute() or PureWindowsPath(name).drive:
        raise InputError(f"refused: {name!r} is an absolute path; the studio reads and writes only inside "
                         f"{root}, so name files relative to it")
    parts = tuple(p for p in PurePosixPath(name.replace("\\", "/")).parts if p != ".")
    if ".." in parts:
        raise InputError(f"refused: {name!r} goes up a folder ('..'); the studio reads and writes only inside {root}")
    if not parts:
        raise InputError("refused: no file named")
    return parts


def inside(folder: Path, name: str) -> Path:
    """``name`` (a path relative to ``folder``, '/'-separated) as a path inside ``folder``.

    Refused with an :class:`InputError` that says why: an empty name, an absolute path, a ``..``
    part, or a path that leaves ``folder`` through a symbolic link.  A name only: what the studio
    opens, it opens with :func:`open_inside` (no check-then-use)."""
    root = folder.resolve()
    candidate = root.joinpath(*_checked_parts(root, name))
    real = Path(os.path.realpath(candidate))
    if real != root and root not in real.parents:
        raise InputError(f"refused: {name!r} is a symbolic link that leads outside {root} (to {real})")
    return candidate


_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_DIRECTORY = getattr(os, "O_DIRECTORY", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


def _link_refusal(name: str, root: Path) -> InputError:
    return InputError(f"refused: {name!r} is a symbolic link (or passes through one); the studio follows no "
                      f"links, so it reads and writes only inside {root}")


def open_folder(folder: Path, name: str, *, create: bool = False) -> tuple[int, str]:
    """(a descriptor of the folder ``name`` is in, ``name``'s last part), opened part by part
    from ``folder`` with ``O_NOFOLLOW`` relative to the part before (``openat``): a symbolic link
    anywhere is refused, and a link swapped in afterwards changes nothing (the descriptor is the
    folder).  ``create`` makes missing folders.  The caller closes the descriptor."""
    root = folder.resolve()
    parts = _checked_parts(root, name)
    fd = os.open(root, os.O_RDONLY | _DIRECTORY | _CLOEXEC)
    try:
        for part in parts[:-1]:
            try:
                sub = os.open(part, os.O_RDONLY | _DIRECTORY | _NOFOLLOW | _CLOEXEC, dir_fd=fd)
            except FileNotFoundError:
                if not create:
                    raise InputError(f"no file {name!r} in {root}") from None
                try:
                    os.mkdir(part, 0o777, dir_fd=fd)
                except FileExistsError:
                    pass  # made meanwhile (another save): opened below, links still refused
                sub = os.open(part, os.O_RDONLY | _DIRECTORY | _NOFOLLOW | _CLOEXEC, dir_fd=fd)
            except (NotADirectoryError, OSError) as exc:
                if isinstance(exc, NotADirectoryError) or exc.errno in (errno.ELOOP, errno.ENOTDIR):
                    if os.path.islink(os.path.join(f"/proc/self/fd/{fd}", part)) or exc.errno == errno.ELOOP:
                        raise _link_refusal(name, root) from None
                    raise InputError(f"cannot open {name!r}: {part!r} is a file, not a folder") from None
                raise
            os.close(fd)
            fd = sub
    except BaseException:
        os.close(fd)
        raise
    return fd, parts[-1]


def open_inside(folder: Path, name: str, what: str = "file") -> int:
    """A descriptor of the regular file ``name`` inside ``folder``, opened for reading once
    (:func:`open_folder`, then the file with ``O_NOFOLLOW``): a link is refused, a FIFO or a
    device is refused without blocking, a missing file is said as such."""
    root = folder.resolve()
    dfd, leaf = open_folder(folder, name)
    try:
        try:
            fd = os.open(leaf, os.O_RDONLY | _NOFOLLOW | os.O_NONBLOCK | _CLOEXEC, dir_fd=dfd)
        except FileNotFoundError:
            raise InputError(f"no {what} {name!r} in {root}") from None
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise _link_refusal(name, root) from None
            raise InputError(f"cannot read {what} {name!r}: {exc.strerror}") from None
    finally:
        os.close(dfd)
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        kind = "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file (a FIFO, device or socket)"
        raise InputError(f"cannot read {what} {name!r}: it is {kind}")
    os.set_blocking(fd, True)
    return fd


@contextlib.contextmanager
def opened(folder: Path, name: str, what: str = "file"):
    """The file ``name`` inside ``folder`` (:func:`open_inside`) as a path a reader can open
    (``/proc/self/fd/N``: the very file opened, not its name looked up again); an error that
    names that path names ``name`` instead."""
    fd = open_inside(folder, name, what)
    proc = f"/proc/self/fd/{fd}" if os.path.isdir("/proc/self/fd") else f"/dev/fd/{fd}"
    shown = str(folder.resolve().joinpath(*_checked_parts(folder, name)))
    try:
        yield Path(proc)
    except HilaError as exc:
        if exc.file == proc:
            exc.file = shown
        exc.message = exc.message.replace(proc, shown)
        raise
    finally:
        os.close(fd)


def folder_templates(folder: Path):
    """A template loader (:class:`hila_lang.language.loader.TemplateLoader`) for the programs the
    studio checks and runs: ``import NAME`` looks in the program's own folder (inside FOLDER),
    FOLDER's ``primitives/`` and the installed templates; ``import "PATH"`` names a file inside
    FOLDER only.  An absolute path, a ``..`` or a link out of FOLDER is simply not a candidate:
    the program gets the same located "not found" error whether that file exists or not, so its
    existence and kind are not revealed."""
    root = folder.resolve()
    installed = Path(shipped("primitives")).resolve()

    def allowed(path: Path) -> bool:
        real = Path(os.path.realpath(path))
        return any(real == base or base in real.parents for base in (root, installed))

    class FolderTemplates(TemplateLoader):
        def folders(self, program_file):
            here = Path(os.path.realpath(program_file)).parent if program_file and not str(program_file).startswith("<") \
                else root
            here = here if allowed(here) else root
            return [here, here / "primitives", root / "primitives", installed]

        def candidates(self, source, is_path, program_file):
            outside = [Path(f"{root} (an import by path stays inside the studio's folder)")]  # named, never read
            if is_path and (PurePosixPath(source).is_absolute() or PureWindowsPath(source).drive
                            or ".." in PurePosixPath(source.replace("\\", "/")).parts):
                return outside
            return [c for c in super().candidates(source, is_path, program_file) if allowed(c)] or outside

        def find(self, source, is_path, program_file):
            return next((c for c in self.candidates(source, is_path, program_file) if allowed(c) and c.is_file()), None)

        def load(self, path):
            path = Path(path)
            if not allowed(path):
                raise InputError(f"refused: {path.name!r} is not inside the studio's folder")
            try:
                inside = path.relative_to(root).as_posix()
            except ValueError:
                return super().load(path)  # an installed template
            # lazy: loads numpy, which importing this module does not
            from ..osila.template import load_template

            # a file in FOLDER is opened once, as every other read of the studio (issue 32): a
            # link swapped in after the check above gives nothing from outside
            with opened(root, inside, "template") as file:
                st = os.stat(file)
                stamp = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
                hit = self._cache.get(str(path))
                if hit is not None and hit[0] == stamp:
                    return hit[1]
                template = load_template(file)
            self._cache[str(path)] = (stamp, template)
            return template

        __call__ = load

    return FolderTemplates()
