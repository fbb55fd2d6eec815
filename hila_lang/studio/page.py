"""What every studio page shares: its declaration, the studio it serves, the door requests come in by.

- :class:`Page`: a page's name (its tab and its state's key on the page, ``window.hilaStudio``),
  title, ES module (in ``static/``) and routes; :mod:`.app` assembles the app from the pages.
- :class:`Studio`: the folder a studio serves and what it keeps while it runs (templates read
  once per change); a handler reaches it as ``request.app.state.studio``.
- :func:`plugins`: the back ends, robots and worlds the registry's plug-ins declare, for the
  pages' menus (an installed plug-in is there as it is for ``hila exec``).
- :func:`read_json` / :func:`read_body`: the one door a request's body comes in by (bounded by
  :data:`.security.MAX_UPLOAD`, checked by its route's shape, :data:`.schema.BODIES`).
- :func:`problem`: what a failed request says (hila's message and hint; an OSError as the file
  and why; ``refused`` for a path or size the studio does not take).
- :class:`JSONSocket`: a websocket of JSON objects, one answer per message, each checked by its
  socket's shape (:data:`.schema.SOCKETS`); a bad message (a binary frame too) or a failed one
  is answered with the reason and the socket goes on.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from starlette.endpoints import WebSocketEndpoint
from starlette.requests import Request
from starlette.websockets import WebSocket

from ..core.errors import HilaError, InputError, internal_error_message
from ..language.environment import Environment
from ..plugins import registry
from .security import folder_templates, inside, MAX_UPLOAD, opened


@dataclass(frozen=True)
class Page:
    """One page of the studio: ``name`` (its tab's ``data-view``, its state's key), ``title``
    (the tab), ``script`` (its ES module under ``static/``) and ``routes`` (Starlette routes)."""

    name: str
    title: str
    script: str
    routes: Sequence[Any] = ()


@dataclass
class Studio:
    """The folder a studio serves (resolved) and the templates read from it, by name and mtime."""

    folder: Path
    _templates: dict = field(default_factory=dict)

    def path(self, name: str) -> Path:
        """``name`` inside the folder (:func:`.security.inside` refuses the rest)."""
        return inside(self.folder, name)

    def template(self, name: str):
        """The template file ``name``, read again only when it changed."""
        # lazy: loads numpy, which importing this module does not
        from ..osila.template import load_template

        with opened(self.folder, name, "template") as path:  # opened once, no link followed
            mtime = path.stat().st_mtime_ns
            cached = self._templates.get(name)
            if cached is None or cached[0] != mtime:
                self._templates[name] = (mtime, load_template(path))
        return self._templates[name][1]


def studio_env(folder: Path | None):
    """The language environment of the programs the studio checks and runs: their imports only
    inside ``folder`` and the installed templates (:func:`.security.folder_templates`); None
    (hila's own) without a folder."""
    return None if folder is None else Environment(templates=folder_templates(folder))


def studio_of(conn: Request | WebSocket) -> Studio:
    return conn.app.state.studio


async def read_body(request: Request, limit: int = MAX_UPLOAD) -> bytes:
    """The request's body, refused (``refused: ...``) past ``limit`` bytes before it is all read."""
    size = request.headers.get("content-length")
    if size is not None and size.isdigit() and int(size) > limit:
        raise InputError(f"refused: the upload is {int(size)} bytes; the studio takes at most {limit} bytes (its upload limit)")
    chunks, total = [], 0
    async for chunk in request.stream():
        total += len(chunk)
        if total > limit:
            raise InputError(f"refused: the upload is over {limit} bytes, the studio's limit")
        chunks.append(chunk)
    return b"".join(chunks)


def json_object(text: str | bytes) -> dict:
    """A JSON object from a request or a websocket message, its nesting bounded
    (:func:`.schema.parse_json`); anything else is an InputError."""
    # lazy: loads numpy, which importing this module does not
    from .schema import parse_json

    return parse_json(text)


async def read_json(request: Request) -> dict:
    """The request's body as a JSON object (:func:`read_body`, :func:`json_object`), checked by
    its route's shape (:data:`.schema.BODIES`; a bad field: 400 naming it)."""
    # lazy: loads numpy, which importing this module does not
    from .schema import BODIES, check

    return check(BODIES[request.url.path], json_object(await read_body(request)))


def problem(exc: BaseException) -> tuple[int, str]:
    """(HTTP status, text) of a failed request: 403 for a refusal, 400 for bad input or a file
    that cannot be read or written, 500 for a bug in hila (said as such, the studio goes on)."""
    if isinstance(exc, HilaError):
        text = exc.message + (f" (hint: {exc.hint})" if exc.hint else "")
        return (403 if exc.message.startswith("refused") else 400), text
    if isinstance(exc, OSError):
        return 400, f"{exc.filename or ''}: {exc.strerror or exc}"
    if isinstance(exc, ValueError):
        return 400, str(exc)
    return 500, internal_error_message(exc)


class JSONSocket(WebSocketEndpoint):
    """A websocket of JSON objects: :meth:`on_message` answers each; a message that is not a
    JSON object, or whose answer fails, is answered by :meth:`on_error` with the reason
    (:func:`problem`'s text), and the socket stays open."""

    encoding = "text"

    async def decode(self, websocket: WebSocket, message) -> str | None:
        """A text frame's text; a binary frame is None (refused by :meth:`on_receive`)."""
        return message.get("text")

    async def on_receive(self, websocket: WebSocket, data: str | None) -> None:
        # lazy: loads numpy, which importing this module does not
        from .schema import SOCKETS, check

        doc: dict = {}
        try:
            if data is None:
                raise InputError("refused: a binary frame; the studio's sockets take JSON text")
            doc = json_object(data)
            doc = check(SOCKETS[websocket.url.path], doc)  # the socket's shape (issue 32)
            await self.on_message(websocket, doc)
        except Exception as exc:  # noqa: BLE001 - said on the page (a bug as such), the socket goes on
            await self.on_error(websocket, doc, problem(exc)[1])

    async def on_message(self, websocket: WebSocket, doc: dict) -> None:
        raise NotImplementedError

    async def on_error(self, websocket: WebSocket, doc: dict, text: str) -> None:
        raise NotImplementedError


def template_json(template) -> dict:
    """A template as the pages draw it."""
    return dict(name=template.name, path=template.path.tolist(),
                times=None if template.times is None else template.times.tolist(),
                icps={k: v.tolist() for k, v in template.icps.items()},
                segments=[dict(tag=s.tag, start=s.start, stop=s.stop, contact=s.contact) for s in template.segments],
                description=template.description, dim=int(template.path.shape[1]))


def plugins() -> dict:
    """What the registry's plug-ins declare, for the page's menus: ``backends``, ``robots`` (the
    default robot first) and ``worlds``, each ``[{name, doc}]`` (a world with its default back end)."""
    # lazy: loads numpy, which importing this module does not
    from ..robot.spec import DEFAULT_ROBOT

    robots = sorted(registry.declarations("robot"), key=lambda r: r.name != DEFAULT_ROBOT)  # the default first
    return dict(backends=[dict(name=b.name, doc=b.doc) for b in registry.declarations("back end")],
                robots=[dict(name=r.name, doc=r.doc) for r in robots],
                worlds=[dict(name=w.name, doc=w.doc, backend=w.default_backend) for w in registry.declarations("world")])
