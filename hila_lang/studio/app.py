"""The studio's app: the pages' routes assembled into one Starlette app behind :class:`.security.Guard`,
and :func:`serve`, which binds 127.0.0.1 and runs it with uvicorn.

Routes of the app itself (every one behind the token, the Host and the Origin check):

- ``GET /`` the page (``static/index.html``); ``GET /static/...`` its scripts and styles;
- ``GET /api/pages`` the pages in tab order: ``[{name, title, script}]`` (the page loads each
  ES module named there);
- the files' routes (:mod:`.files`) and each page's own (:data:`PAGES`).

A failed request is answered by Starlette's ``exception_handlers`` as ``{"error": TEXT}`` with the
status :func:`.page.problem` gives (403 refused, 400 bad input or a file problem, 500 a bug in
hila, which the studio survives; its traceback goes to the server's log).
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import importlib
import socket
import sys
import threading
from importlib import resources
from pathlib import Path

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from ..core.errors import HilaError
from ..core.fileio import remove_stale_staging
from . import demonstrate, files, imitate, run, worker
from .page import problem, Studio
from .security import cookie_name, Guard, MAX_UPLOAD, new_token

#: seconds Ctrl-C waits for requests under way before it cancels them (and kills the workers)
SHUTDOWN_S = 0.1

#: the pages, in tab order; a new page is its module here, its script in static/ and its test
PAGES = (demonstrate.PAGE, imitate.PAGE, run.PAGE)


def static_dir() -> Path:
    return Path(str(resources.files("hila_lang.studio") / "static"))


async def answer_problem(request: Request, exc: Exception) -> Response:
    status, text = problem(exc)
    if isinstance(exc, files.Exists):  # the overwrite contract: 409, the page asks the person
        return JSONResponse({"error": text, "exists": True}, status_code=409)
    return JSONResponse({"error": text}, status_code=status)


#: every failure a handler may raise, answered by :func:`answer_problem`.  A bug in hila
#: (``Exception``) is answered the same way, 500 with where it was raised; Starlette then raises it
#: again for the server, which logs its traceback -- the report's material -- and the studio goes on.
EXCEPTION_HANDLERS = {HilaError: answer_problem, OSError: answer_problem, ValueError: answer_problem,
                      Exception: answer_problem}


def make_app(folder: Path, token: str, port: int):
    """The studio's ASGI app over ``folder`` for the studio at 127.0.0.1:``port``."""

    async def index(request: Request) -> Response:
        response = FileResponse(static_dir() / "index.html", headers={"cache-control": "no-store"})
        given = request.query_params.get("token")
        if given:
            response.set_cookie(cookie_name(port), given, httponly=True, samesite="strict")
        return response

    async def pages(request: Request) -> Response:
        return JSONResponse([dict(name=p.name, title=p.title, script=p.script) for p in PAGES])

    routes = [
        Route("/", index),
        Route("/favicon.ico", lambda request: Response(status_code=204)),
        Route("/api/pages", pages),
        *files.ROUTES,
        *(route for page in PAGES for route in page.routes),
        Mount("/static", app=StaticFiles(directory=static_dir())),
    ]
    app = Starlette(routes=routes, exception_handlers=EXCEPTION_HANDLERS)
    app.state.studio = Studio(Path(folder).resolve())
    return Guard(app, token, port)


def _server_class():
    # lazy: loads uvicorn, which importing this module does not
    import uvicorn

    class Server(uvicorn.Server):
        """uvicorn's server, stopped at once by Ctrl-C (SIGTERM): the signal first kills the workers
        (from a thread: the handler may have interrupted the main thread inside :mod:`.worker`'s
        lock), so requests under way are answered at once and the shutdown does not wait for their
        work; and it wakes the main loop, which otherwise looks for a stop only every 0.1 s (and
        the shutdown waits no fixed time: uvicorn's sleeps 0.1 s twice)."""

        async def main_loop(self) -> None:
            self._woken = asyncio.Event()
            self._loop = asyncio.get_running_loop()
            counter = 0
            while not await self.on_tick(counter):  # uvicorn's loop: its tick (the Date header) each 0.1 s
                counter = (counter + 1) % 864000
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(self._woken.wait(), 0.1)

        async def shutdown(self, sockets=None) -> None:
            """uvicorn's shutdown without its fixed 0.1 s sleeps: connections are asked to close,
            requests under way get up to :data:`SHUTDOWN_S` (looked at every 10 ms), then cancelled."""
            for server in self.servers:
                server.close()
            for sock in sockets or []:
                sock.close()
            for connection in list(self.server_state.connections):
                connection.shutdown()
            loop = asyncio.get_running_loop()
            end = loop.time() + self.config.timeout_graceful_shutdown
            while (self.server_state.connections or self.server_state.tasks) and loop.time() < end:
                await asyncio.sleep(0.01)
            for task in list(self.server_state.tasks):
                task.cancel()

        def handle_exit(self, sig, frame) -> None:
            threading.Thread(target=worker.stop, args=(True,), daemon=True).start()
            super().handle_exit(sig, frame)
            loop = getattr(self, "_loop", None)
            if loop is not None and not loop.is_closed():
                loop.call_soon_threadsafe(self._woken.set)

    return Server


#: third-party packages the server's threads would otherwise import lazily (checking a program, a
#: world's scene image, a run in PyBullet): imported once in the main thread before serving.  Two
#: threads importing parts of SciPy (or OpenCV) for the first time at once can each find the
#: other's module half imported (circular imports inside SciPy): a CI run's page failed with
#: "cannot import name 'PytestTester' from partially initialized module 'scipy._lib._testutils'",
#: and 8 threads importing these at once failed in 2 of 6 fresh processes here.
THREAD_IMPORTS = ("scipy.sparse", "scipy.linalg", "scipy.spatial", "scipy.spatial.transform", "scipy.spatial.distance",
                  "scipy.interpolate", "scipy.optimize", "scipy.ndimage", "scipy.signal", "cv2")


def import_for_threads() -> None:
    """Import :data:`THREAD_IMPORTS` now (in this thread); a package that is not installed is left
    to the code that needs it (its own error names it)."""
    for name in THREAD_IMPORTS:
        with contextlib.suppress(ImportError):
            importlib.import_module(name)


def serve(folder: Path, port: int = 0, *, open_browser: bool = False, token: str | None = None) -> int:
    """Bind 127.0.0.1:``port`` (0: a free one), print the URL line, serve until Ctrl-C.

    Returns 2 when the port is taken (one line says so); Ctrl-C raises KeyboardInterrupt after
    the server has shut down (the CLI maps it to 130)."""
    # lazy: loads uvicorn, which importing this module does not
    import uvicorn

    _Server = _server_class()
    token = token or new_token()
    for name in remove_stale_staging(folder):  # a studio killed during a save left it: nothing of it was published
        print(f"hila studio: removed {name}, the staging folder of a studio stopped during a save", file=sys.stderr)
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    # SO_REUSEADDR: a restart on the same --port right after requests binds at once (without it the
    # connections' TIME_WAIT held the port ~60 s); two listeners on one port are still refused
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
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
    # timeout_graceful_shutdown: Ctrl-C (or SIGTERM) waits at most this long for requests under
    # way (their heavy work is in workers, killed then), so the studio stops within a second.
    # Loaded now (uvicorn's protocols imported), before the URL line: once it is printed, starting
    # to serve takes milliseconds, and a Ctrl-C right after it finds no import under way
    config = uvicorn.Config(make_app(folder, token, port), log_level="warning", lifespan="off",
                            ws_max_size=MAX_UPLOAD, timeout_graceful_shutdown=SHUTDOWN_S)
    config.load()
    import_for_threads()
    url = f"http://127.0.0.1:{port}/?token={token}"
    print(f"hila studio: {url}", flush=True)
    print(f"serving {folder.resolve()} (Ctrl-C to stop)", flush=True)
    if open_browser:
        # lazy: only this branch needs it
        import webbrowser

        webbrowser.open(url)
    server = _Server(config)
    worker.warm()
    try:
        server.run(sockets=[sock])
    finally:
        worker.stop(final=True)
    return 0
