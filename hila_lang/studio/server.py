"""The studio's web server: a Starlette app behind :class:`.security.Guard`, served by uvicorn.

Routes (every one behind the token, the Host and the Origin check):

- ``GET /`` the page; ``GET /static/...`` its scripts and styles (from the package);
- ``GET /api/files`` the folder's templates, programs, demonstrations, pictures and recordings;
- ``GET|PUT /api/file?path=`` a text file (a program) read / written atomically;
- ``GET /api/raw?path=`` a file's bytes (an uploaded picture); ``POST /api/upload?path=`` a file
  up to :data:`.security.MAX_UPLOAD` bytes, written atomically;
- ``GET /api/scene?name=`` and ``/api/scene-image/NAME``: what the person draws on;
- ``POST /api/demonstration``: pointer samples -> path, times, speed and proposed cuts;
- ``POST /api/save``: the template, through ``hila learn``'s command; ``GET /api/open``: a
  template, CSV or LASA shape to edit; ``GET /api/lasa``: the LASA shapes;
- ``POST /api/check``: the program's located problems (``hila lsp``'s);
- ``POST /api/imitate/export``: the path as CSV and the scene as a ``.hila`` snippet; ``POST
  /api/imitate/explain``: ``hila explain``'s account;
- websocket ``/ws/imitate``: a scene in, OSILA's path out, while the person drags;
- websocket ``/ws/run``: a run or a recording, stepped by the page's buttons.
"""

from __future__ import annotations

import asyncio
import json
from importlib import resources
from pathlib import Path

from ..core.errors import HilaError, InputError
from .security import MAX_UPLOAD, Guard, cookie_name, inside

LISTED = (".yaml", ".hila", ".csv", ".hilarec", ".png", ".jpg", ".jpeg")


def static_dir() -> Path:
    return Path(str(resources.files("hila_lang.studio") / "static"))


def make_app(folder: Path, token: str, port: int):
    """The studio's ASGI app over ``folder`` for the studio at 127.0.0.1:``port``."""
    from starlette.applications import Starlette
    from starlette.concurrency import run_in_threadpool
    from starlette.requests import Request
    from starlette.responses import FileResponse, JSONResponse, PlainTextResponse, Response
    from starlette.routing import Mount, Route, WebSocketRoute
    from starlette.staticfiles import StaticFiles
    from starlette.websockets import WebSocket, WebSocketDisconnect

    from . import demonstrate, imitate
    from .frontend import analyse

    folder = Path(folder).resolve()
    templates: dict[str, tuple[float, object]] = {}

    def problem(exc: Exception, status: int = 400) -> Response:
        text = exc.message if isinstance(exc, HilaError) else str(exc)
        if isinstance(exc, HilaError) and exc.hint:
            text += f" (hint: {exc.hint})"
        return JSONResponse({"error": text}, status_code=status)

    def guarded(handler):
        async def wrapped(request: Request) -> Response:
            try:
                return await handler(request)
            except (HilaError, OSError, ValueError) as exc:
                if isinstance(exc, OSError) and not isinstance(exc, HilaError):
                    return problem(InputError(f"{exc.filename or ''}: {exc.strerror or exc}"), 400)
                return problem(exc, 403 if str(getattr(exc, "message", exc)).startswith("refused") else 400)
            except Exception as exc:  # noqa: BLE001 - a bug in hila: said as such, the studio goes on
                from ..core.errors import internal_error_message

                return JSONResponse({"error": internal_error_message(exc)}, status_code=500)
        return wrapped

    def template(name: str):
        path = inside(folder, name)
        mtime = path.stat().st_mtime
        cached = templates.get(name)
        if cached is None or cached[0] != mtime:
            templates[name] = (mtime, imitate.load(folder, name))
        return templates[name][1]

    async def body(request: Request, limit: int = MAX_UPLOAD) -> bytes:
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

    async def json_body(request: Request) -> dict:
        try:
            doc = json.loads(await body(request))
        except json.JSONDecodeError as exc:
            raise InputError(f"expected a JSON body: {exc}") from None
        if not isinstance(doc, dict):
            raise InputError("expected a JSON object")
        return doc

    async def index(request: Request) -> Response:
        response = FileResponse(static_dir() / "index.html", headers={"cache-control": "no-store"})
        given = request.query_params.get("token")
        if given:
            response.set_cookie(cookie_name(port), given, httponly=True, samesite="strict")
        return response

    @guarded
    async def files(request: Request) -> Response:
        found = []
        for p in sorted(folder.rglob("*")):
            rel = p.relative_to(folder)
            if any(part.startswith(".") for part in rel.parts) or not p.is_file() or p.suffix.lower() not in LISTED:
                continue
            if len(rel.parts) > 3:
                continue
            try:
                inside(folder, rel.as_posix())
            except InputError:
                continue  # a symlink out is not listed
            found.append(rel.as_posix())
        return JSONResponse({"folder": str(folder), "files": found[:2000]})

    @guarded
    async def file(request: Request) -> Response:
        from ..core.fileio import atomic_write_text, read_text

        path = inside(folder, request.query_params.get("path", ""))
        if request.method == "PUT":
            data = await body(request)
            try:
                text = data.decode("utf-8")
            except UnicodeDecodeError:
                raise InputError("expected UTF-8 text") from None
            atomic_write_text(path, text)
            return JSONResponse({"saved": path.relative_to(folder).as_posix(), "bytes": len(data)})
        return PlainTextResponse(read_text(path, "file"))

    @guarded
    async def raw(request: Request) -> Response:
        from ..core.fileio import read_bytes

        path = inside(folder, request.query_params.get("path", ""))
        return Response(read_bytes(path, "file"), media_type="application/octet-stream")

    @guarded
    async def upload(request: Request) -> Response:
        from ..core.fileio import atomic_write_bytes

        path = inside(folder, request.query_params.get("path", ""))
        data = await body(request)
        atomic_write_bytes(path, data)
        return JSONResponse({"saved": path.relative_to(folder).as_posix(), "bytes": len(data)})

    @guarded
    async def scene(request: Request) -> Response:
        name = request.query_params.get("name", "blank")
        return JSONResponse(await run_in_threadpool(demonstrate.scene, name, folder))

    @guarded
    async def scene_image(request: Request) -> Response:
        data = await run_in_threadpool(demonstrate.scene_image, request.path_params["name"])
        return Response(data, media_type="image/png")

    @guarded
    async def demonstration(request: Request) -> Response:
        doc = await json_body(request)

        def work():
            if "samples" in doc:
                path, times = demonstrate.demonstration_path(doc["samples"], doc.get("z"))
            else:
                import numpy as np

                path = np.asarray(doc["path"], float)
                times = np.asarray(doc["times"] if doc.get("times") is not None else np.arange(len(path)) * 0.05)
            out = dict(path=path.tolist(), times=times.tolist())
            k = int(doc.get("k", 3))
            out.update(demonstrate.proposal(path, times, k, doc.get("method", "speed"), doc.get("seed", 0)))
            return out
        return JSONResponse(await run_in_threadpool(work))

    @guarded
    async def save(request: Request) -> Response:
        doc = await json_body(request)
        return JSONResponse(await run_in_threadpool(demonstrate.save, folder, doc))

    @guarded
    async def open_source(request: Request) -> Response:
        q = request.query_params
        return JSONResponse(await run_in_threadpool(demonstrate.open_source, folder, q.get("kind", ""), q.get("name", "")))

    @guarded
    async def lasa(request: Request) -> Response:
        from ..evaluation import lasa as data

        return JSONResponse({"shapes": list(data.all_shapes()) if data.available() else []})

    @guarded
    async def check(request: Request) -> Response:
        doc = await json_body(request)
        path = inside(folder, str(doc.get("path") or "untitled.hila"))
        return JSONResponse(await run_in_threadpool(analyse, path, str(doc.get("text", ""))))

    @guarded
    async def export(request: Request) -> Response:
        doc = await json_body(request)
        name = str(doc.get("template", ""))
        t = template(name)
        result = await run_in_threadpool(imitate.imitate, t, doc)
        if "error" in result:
            raise InputError(result["error"])
        stem = Path(name).stem
        return JSONResponse({"csv": imitate.path_csv(result["path"], t.times),
                             "hila": imitate.snippet(t, doc, stem)})

    @guarded
    async def explain(request: Request) -> Response:
        doc = await json_body(request)
        t = template(str(doc.get("template", "")))
        return JSONResponse({"lines": await run_in_threadpool(imitate.explain, t, doc)})

    @guarded
    async def template_json(request: Request) -> Response:
        return JSONResponse(demonstrate.template_json(template(request.query_params.get("path", ""))))

    async def ws_imitate(ws: WebSocket) -> None:
        await ws.accept()
        try:
            while True:
                doc: dict = {}
                text = await ws.receive_text()
                try:
                    doc = json.loads(text)
                    if not isinstance(doc, dict):
                        doc = {}
                        raise InputError("expected a JSON object")
                    out = await run_in_threadpool(imitate.imitate, template(str(doc.get("template", ""))), doc)
                except (HilaError, ValueError, OSError) as exc:
                    out = {"error": getattr(exc, "message", None) or str(exc)}
                except Exception as exc:  # noqa: BLE001 - a bug: said on the page, the studio goes on
                    from ..core.errors import internal_error_message

                    out = {"error": internal_error_message(exc)}
                out["seq"] = doc.get("seq")
                await ws.send_text(json.dumps(out))
        except WebSocketDisconnect:
            pass

    async def ws_run(ws: WebSocket) -> None:
        from .session import ReplaySession, RunSession, fsm_graph

        await ws.accept()
        loop = asyncio.get_running_loop()
        outbox: asyncio.Queue = asyncio.Queue()

        def emit(msg: dict) -> None:
            loop.call_soon_threadsafe(outbox.put_nowait, msg)

        async def pump():
            while True:
                await ws.send_text(json.dumps(await outbox.get()))

        pumping = asyncio.create_task(pump())
        session = None
        try:
            while True:
                text = await ws.receive_text()
                try:
                    doc = json.loads(text)
                    cmd = doc.get("cmd") if isinstance(doc, dict) else None
                    if cmd in ("start", "open"):
                        if session is not None:
                            await run_in_threadpool(session.close)
                            session = None
                        path = inside(folder, str(doc.get("path", "")))
                        if cmd == "start":
                            from ..core.fileio import read_text

                            # an opponent only for a world that has one (the page offers it to every program)
                            known = (await run_in_threadpool(analyse, path, read_text(path, "program")))["settings"]
                            opponent = doc.get("opponent") if "opponent" in known else None
                            session = await run_in_threadpool(lambda: RunSession(
                                path, emit, backend=doc.get("backend") or None,
                                opponent=opponent or None, seed=int(doc.get("seed", 0)),
                                robot=str(doc.get("robot") or "") or None))
                        else:
                            session = await run_in_threadpool(ReplaySession, path, emit)
                        emit(dict(type="fsm", graph=fsm_graph(session.interp.fsm),
                                  length=getattr(session, "length", None)))
                        emit(session.snapshot())
                    elif session is None:
                        raise InputError("open a program (Run) or a recording first")
                    elif cmd in ("step", "run", "back", "reload"):
                        line = cmd if cmd != "step" else f"step {int(doc.get('n', 1))}"
                        if hasattr(session, "resume"):
                            session.resume(line)
                        else:
                            session.command(line)
                    elif cmd in ("break", "clear"):
                        session.command(f"{cmd} {doc.get('state', '')}")
                    elif cmd == "stop":
                        if hasattr(session, "stop"):
                            session.stop()
                    elif cmd == "view":
                        if hasattr(session, "turn"):
                            await run_in_threadpool(session.turn, float(doc.get("azimuth", 35)))
                    elif cmd == "move":
                        session.move(int(doc["cell"]))
                    elif cmd == "scrub":
                        await run_in_threadpool(session.scrub, int(doc.get("n", 0)))
                    else:
                        raise InputError(f"unknown command {cmd!r}")
                except (HilaError, ValueError, OSError) as exc:
                    emit({"type": "error", "text": getattr(exc, "message", None) or str(exc)})
                except Exception as exc:  # noqa: BLE001 - a bug: said on the page, the studio goes on
                    from ..core.errors import internal_error_message

                    emit({"type": "error", "text": internal_error_message(exc)})
        except WebSocketDisconnect:
            pass
        finally:
            pumping.cancel()
            if session is not None:
                await run_in_threadpool(session.close)

    routes = [
        Route("/", index),
        Route("/favicon.ico", lambda request: Response(status_code=204)),
        Route("/api/files", files),
        Route("/api/file", file, methods=["GET", "PUT"]),
        Route("/api/raw", raw),
        Route("/api/upload", upload, methods=["POST"]),
        Route("/api/scene", scene),
        Route("/api/scene-image/{name}", scene_image),
        Route("/api/demonstration", demonstration, methods=["POST"]),
        Route("/api/save", save, methods=["POST"]),
        Route("/api/open", open_source),
        Route("/api/lasa", lasa),
        Route("/api/check", check, methods=["POST"]),
        Route("/api/template", template_json),
        Route("/api/imitate/export", export, methods=["POST"]),
        Route("/api/imitate/explain", explain, methods=["POST"]),
        WebSocketRoute("/ws/imitate", ws_imitate),
        WebSocketRoute("/ws/run", ws_run),
        Mount("/static", app=StaticFiles(directory=static_dir())),
    ]
    return Guard(Starlette(routes=routes), token, port)


def serve(folder: Path, port: int = 0, *, open_browser: bool = False, token: str | None = None) -> int:
    """Bind 127.0.0.1:``port`` (0: a free one), print the URL line, serve until Ctrl-C.

    Returns 2 when the port is taken (one line says so); Ctrl-C raises KeyboardInterrupt after
    the server has shut down (the CLI maps it to 130)."""
    import errno
    import socket
    import sys

    import uvicorn

    from .security import new_token

    token = token or new_token()
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind(("127.0.0.1", port))
    except OSError as exc:
        sock.close()
        if exc.errno in (errno.EADDRINUSE, errno.EACCES):
            print(f"hila studio: port {port} on 127.0.0.1 is taken (or not allowed); "
                  "choose another with --port N, or --port 0 for a free one", file=sys.stderr)
            return 2
        raise
    sock.listen(128)  # connections wait in the backlog from now on, before uvicorn takes the socket
    port = sock.getsockname()[1]
    url = f"http://127.0.0.1:{port}/?token={token}"
    print(f"hila studio: {url}", flush=True)
    print(f"serving {folder.resolve()} (Ctrl-C to stop)", flush=True)
    if open_browser:
        import webbrowser

        webbrowser.open(url)
    config = uvicorn.Config(make_app(folder, token, port), log_level="warning", lifespan="off",
                            ws_max_size=MAX_UPLOAD)
    server = uvicorn.Server(config)
    server.run(sockets=[sock])
    return 0
