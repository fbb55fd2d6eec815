"""What every studio page shares: its declaration, the studio it serves, the door requests come in by.

- :class:`Page`: a page's name (its tab and its state's key on the page, ``window.hilaStudio``),
  title, ES module (in ``static/``) and routes; :mod:`.app` assembles the app from the pages.
- :class:`Studio`: the folder a studio serves and what it keeps while it runs (templates read
  once per change); a handler reaches it as ``request.app.state.studio``.
- :func:`plugins`: the back ends, robots and worlds the registry's plug-ins declare, for the
  pages' menus (an installed plug-in is there as it is for ``hila exec``).
- :func:`read_json` / :func:`read_body`: the one door a request's body comes in by (bounded by
  :data:`.security.MAX_UPLOAD`, JSON by :data:`.schema.MAX_JSON`, checked by its route's shape,
  :data:`.schema.BODIES`, in a thread: the event loop goes on answering).
- :func:`problem`: what a failed request says (hila's message and hint; an OSError as the file
  and why; ``refused`` for a path or size the studio does not take).
- :class:`JSONSocket`: a websocket of JSON objects, one answer per message, each checked by its
  socket's shape (:data:`.schema.SOCKETS`); a bad message (a binary frame too) or a failed one
  is answered with the reason and the socket goes on.
- :func:`gone` / :func:`opened_in_thread`: a page that goes away (its request's connection or
  its websocket closed) stops the work it asked for, instead of leaving it to run to its budget.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from starlette.concurrency import run_in_threadpool
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


def checked_json(text: str | bytes, shape) -> dict:
    """``text`` as a JSON object (:func:`json_object`) checked by ``shape``: a bad field is an
    InputError naming it.  Called in a thread (:func:`read_json`, :class:`JSONSocket`): a large
    body takes a fraction of a second, which the event loop does not wait for."""
    # lazy: loads numpy, which importing this module does not
    from .schema import check, MAX_JSON

    if len(text) > MAX_JSON:
        raise InputError(f"refused: the JSON is {len(text)} bytes; the studio takes at most {MAX_JSON} bytes of JSON "
                         "in one request or message")
    return check(shape, json_object(text))


async def read_json(request: Request) -> dict:
    """The request's body as a JSON object (:func:`read_body`, at most :data:`.schema.MAX_JSON`
    bytes), checked by its route's shape (:data:`.schema.BODIES`; a bad field: 400 naming it),
    parsed and checked in a thread (:func:`checked_json`)."""
    # lazy: loads numpy, which importing this module does not
    from .schema import BODIES, MAX_JSON

    body = await read_body(request, MAX_JSON)
    return await run_in_threadpool(checked_json, body, BODIES[request.url.path])


async def gone(request: Request) -> None:
    """Returns when the request's connection has closed (the page went away, or was reloaded):
    after the body is read, the next message uvicorn gives is ``http.disconnect``, at the close.
    :func:`.worker.run` stops the request's work then."""
    while (await request.receive())["type"] != "http.disconnect":
        pass


async def opened_in_thread(make):
    """``make()`` in a thread, awaited; when the await is cancelled meanwhile (the page went away)
    what ``make`` returns is closed as soon as it is made (``.close()`` in a thread), not left running."""
    task = asyncio.ensure_future(run_in_threadpool(make))
    try:
        return await asyncio.shield(task)
    except asyncio.CancelledError:
        task.add_done_callback(lambda f: f.cancelled() or f.exception() or threading.Thread(
            target=f.result().close, daemon=True).start())
        raise


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
    (:func:`problem`'s text), and the socket stays open.  Messages are answered one at a time
    while the socket is still read, so a page that goes away cancels the answer under way (its
    work in a worker is killed: :func:`.worker.run`) instead of leaving it to run to its budget."""

    encoding = "text"
    #: messages read ahead of the one being answered (then reading waits)
    READ_AHEAD = 4

    async def dispatch(self) -> None:
        websocket = WebSocket(self.scope, receive=self.receive, send=self.send)
        await self.on_connect(websocket)
        inbox: asyncio.Queue = asyncio.Queue(self.READ_AHEAD)

        async def answer() -> None:
            while True:
                await self.on_receive(websocket, await inbox.get())

        answering, close_code = asyncio.create_task(answer()), 1000
        try:
            while True:
                message = await websocket.receive()
                if message["type"] == "websocket.disconnect":
                    close_code = int(message.get("code") or 1000)
                    break
                if message["type"] == "websocket.receive":
                    await inbox.put(await self.decode(websocket, message))
        except Exception:
            close_code = 1011
            raise
        finally:
            answering.cancel()  # the page went away: the answer under way (and its work) is stopped
            with contextlib.suppress(asyncio.CancelledError):
                await answering
            await self.on_disconnect(websocket, close_code)

    async def decode(self, websocket: WebSocket, message) -> str | None:
        """A text frame's text; a binary frame is None (refused by :meth:`on_receive`)."""
        return message.get("text")

    async def on_receive(self, websocket: WebSocket, data: str | None) -> None:
        # lazy: loads numpy, which importing this module does not
        from .schema import SOCKETS

        doc: dict = {}
        try:
            if data is None:
                raise InputError("refused: a binary frame; the studio's sockets take JSON text")
            doc = await run_in_threadpool(checked_json, data, SOCKETS[websocket.url.path])  # the socket's shape
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
