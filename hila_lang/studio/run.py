"""The Run page: a program checked as it is typed (``POST /api/check``: ``hila lsp``'s analysis and
what the program's world offers here), run on a back end and a robot (the registry's, ``GET
/api/plugins``: :func:`.page.plugins`) or a recording replayed, and watched.  The websocket
``/ws/run`` holds one :class:`Session`: ``{"cmd": "start", path, backend, robot, settings, seed}``
opens a :class:`RunSession` (the run ``hila repl`` builds, :func:`hila_lang.session.runner.prepare`),
``{"cmd": "open", path}`` a :class:`ReplaySession` (a ``.hilarec``: its program's text comes too);
both under :class:`hila_lang.session.repl.Repl`, both answer :data:`COMMANDS`: the REPL's commands
in a worker thread, one at a time, ``stop``, ``answer`` (a person's line to the world: a board's
button), ``view`` (turn the 3-D view), ``scrub``; what a session cannot do it says.  After each
step the page gets the state, the trace line, the world's board, the left eye's image, the 3-D
view (:mod:`hila_lang.session.view3d`), ``failed`` (the state that failed, its line and message,
until the next step, back or reload) and ``outcome`` (at the end: who won, the world's words)."""

from __future__ import annotations

import asyncio
import base64
import contextlib
import io
import json
import queue
import tempfile
import threading
from pathlib import Path

from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route, WebSocketRoute
from starlette.websockets import WebSocket

from ..core.errors import HilaError, InputError, internal_error_message
from ..core.fileio import png_bytes
from ..lsp.analysis import Document
from ..plugins import registry
from ..plugins.options import RunOptions
from ..plugins.studio import StudioView
from ..session.replay import ReplayEngine
from ..session.repl import Repl
from ..session.runner import finish, prepare
from ..session.view3d import render
from . import files
from .page import JSONSocket, opened_in_thread, Page, plugins, read_json, studio_env, studio_of
from .photoscene import offer_pictures, picture_file
from .security import inside


def analyse(path: Path, text: str, folder: Path | None = None) -> dict:
    """The program ``text`` (as if at ``path``) for the page: ``problems`` as ``hila lsp`` locates
    them (0-based ``line``, ``character``, ...), the ``settings`` its world declares, and what the
    world's studio view offers: ``offered`` ({setting: {value: label}}; with the folder's pictures,
    :func:`.photoscene.offer_pictures`) and ``hint``; ``image``: the setting naming a picture (or None)."""
    doc = Document(str(path), env=studio_env(folder))  # imports only inside the studio's folder (issue 32)
    problems = [dict(line=p.line, character=p.character, end_line=p.end_line, end_character=p.end_character,
                     message=p.message, severity=p.severity) for p in doc.analyse(text)]
    world = doc.world()
    view = (world.studio if world is not None else None) or StudioView()
    return dict(problems=problems, settings=[s.name for s in world.settings] if world is not None else [],
                offered=offer_pictures(view, folder, text), hint=view.hint, image=view.picture_setting or None)


class LineInput(io.TextIOBase):
    """``stdin`` of a world that asks a person: ``readline`` waits for a line the page sends."""

    def __init__(self, on_wait) -> None:
        self._lines: queue.Queue[str] = queue.Queue()
        self.waiting, self._on_wait = False, on_wait

    def put(self, text: str) -> None:
        self._lines.put(text.rstrip("\n") + "\n")

    def readline(self, *args) -> str:  # noqa: D401
        self.waiting = True
        self._on_wait()
        try:
            return self._lines.get()
        finally:
            self.waiting = False

    def isatty(self) -> bool:
        return True  # a person answers: the world does not echo the line


class Output(io.TextIOBase):
    """``stdout`` of the REPL and the world: each write goes to the page."""

    def __init__(self, emit) -> None:
        self._emit = emit

    def write(self, text: str) -> int:
        if text:
            self._emit({"type": "out", "text": text})
        return len(text)


def fsm_graph(fsm) -> dict:
    """Nodes and edges of the state machine, for drawing."""
    return dict(start=fsm.start,
                nodes=[dict(name=s.name, kind=s.kind, line=s.line) for s in fsm.states.values()],
                edges=[[s.name, target, label] for s in fsm.states.values() for target, label in s.edges()])


def _png(rgb) -> str:
    return base64.b64encode(png_bytes(rgb)).decode()


class Session:
    """What the Run page steps under the REPL, one command at a time: ``interp`` is its engine,
    ``length``/``program`` a recording's steps/text (None: a run); the base class answers as a recording does."""

    length: int | None = None
    program: str | None = None

    def __init__(self, emit) -> None:
        self.emit, self.repl, self.interp, self.failed, self._lock = emit, None, None, None, threading.Lock()

    def command(self, line: str) -> None:
        """Run one REPL command in a worker thread (one at a time: a second waits its turn)."""
        def work():
            with self._lock:
                try:
                    self.repl.onecmd(line)
                except Exception as exc:  # noqa: BLE001 - a bug: said on the page, lit as failed; the session goes on
                    text, at = internal_error_message(exc), self.interp.current
                    self.emit({"type": "out", "text": text + "\n"})
                    where = self.interp.fsm.states[at].line if at in self.interp.fsm.states else None
                    self.failed = dict(state=at, line=where or None, message=text.splitlines()[0])
                self.emit(self.snapshot())
        threading.Thread(target=work, daemon=True).start()

    def resume(self, line: str) -> None:
        """Step or run on (a run first forgets a ``stop``)."""
        self.command(line)

    def stop(self) -> None:
        """Stop a run before its next state (a recording stops by itself)."""

    def answer(self, text: str) -> None:
        raise InputError("a recording takes no answers: it replays the moves it recorded")

    def turn(self, azimuth: float) -> None:
        """Turn the 3-D view (a recording has none)."""

    def scrub(self, n: int) -> None:
        raise InputError("only a recording scrubs; step a run with Step, Run or Back")

    def snapshot(self) -> dict:
        """The state for the page: where the engine is, its steps, its last path, and :meth:`details`."""
        it, path = self.interp, self.interp.last_path
        return dict(type="state", current=None if it.done else it.current, done=it.done, steps=it.trace.total,
                    path=None if path is None else path.tolist(), failed=self.failed, **self.details())

    def details(self) -> dict:
        raise NotImplementedError

    def close(self) -> None:
        pass


class RunSession(Session):
    """A program run on a back end, stepped by the page's buttons (``text``: the program's, read once)."""

    def __init__(self, program: Path, emit, *, backend: str | None = None, settings: dict | None = None,
                 seed: int = 0, robot: str | None = None, folder: Path | None = None, text: str | None = None) -> None:
        super().__init__(emit)
        self.stdin, self.stdout = LineInput(lambda: self.emit(self.snapshot())), Output(emit)
        self._out = tempfile.TemporaryDirectory(prefix="hila-studio-")
        settings = dict(settings or {}, **({"robot": robot} if robot else {}))  # --robot NAME: the arm that runs
        self.options = RunOptions(seed=seed, out=Path(self._out.name), settings=settings, stdin=self.stdin,
                                  stdout=self.stdout)
        self.interp = prepare(program, self.options, backend, env=(env := studio_env(folder)), text=text)
        view = registry.world(self.interp.checked.world).studio
        self._board, self._outcome = (view.load(a) if view and getattr(view, a) else None for a in ("board", "outcome"))
        reload = None if folder is None else files.program_loader(folder, env)  # read again as at the start
        self.repl = Repl(self.interp, stdin=io.StringIO(), stdout=self.stdout, load=reload)
        self.interp.observers.append(self._observe)
        self.last_eye = self.robot = None  # base64 PNGs: the left eye's last image, the 3-D view
        self.azimuth = 35.0
        self._view()

    def _observe(self, entry) -> None:
        if entry.error is not None:  # a failed step: lit on the page, its message at the top
            self.failed = dict(state=entry.state, line=entry.line or None, step=entry.step, message=entry.error)
        if entry.kind == "run":
            eyes = self.interp.backend.eyes
            try:
                self.last_eye = None if eyes is None else _png(eyes.camera_image("left").rgb)
            except Exception:  # noqa: BLE001 - no picture is not a failed step
                self.last_eye = None
            self._view(entry)
        self.emit(dict(self.snapshot(), type="step", entry=str(entry)))

    def _view(self, entry=None) -> None:
        """The 3-D view now, with the last run state's planned and executed paths."""
        entry = entry or self.interp.last_run
        try:
            rgb = render(self.interp.backend, self.azimuth, None if entry is None else entry.path,
                         None if entry is None else entry.executed)
        except Exception:  # noqa: BLE001 - no picture is not a failed step
            rgb = None
        self.robot = None if rgb is None else _png(rgb)

    def turn(self, azimuth: float) -> None:
        self.azimuth = float(azimuth) % 360.0
        with self._lock:
            self._view()
            self.emit(self.snapshot())

    def details(self) -> dict:
        board = None if self._board is None else self._board(self.interp.world)
        outcome = self._outcome(self.interp.world) if self._outcome is not None and self.interp.done else None
        return dict(waiting=self.stdin.waiting, board=None if board is None else board.to_json(), eye=self.last_eye,
                    outcome=outcome, robot=self.robot, arm=self.options.robot.name,  # the arm that runs
                    breakpoints=list(self.repl.breakpoints) if self.repl else [])

    def answer(self, text: str) -> None:
        self.stdin.put(text)

    def stop(self) -> None:
        if "*" not in self.repl.breakpoints:
            self.repl.breakpoints.append("*")
        if self.stdin.waiting:
            self.stdin.put("q")

    def resume(self, line: str) -> None:
        if "*" in self.repl.breakpoints:
            self.repl.breakpoints.remove("*")
        self.failed = None  # stepped on, back or reloaded: a new failure says itself
        self.command(line)

    def close(self) -> None:
        self.stop()  # a run under way stops before its next state (the page went away)
        with self._lock, contextlib.suppress(HilaError):
            finish(self.interp)
        self._out.cleanup()


class ReplaySession(Session):
    """A recording (``.hilarec``), scrubbed step by step without a simulator; ``name`` in ``folder``
    held open while the session lasts (:func:`.files.read_recording`)."""

    def __init__(self, folder: Path, name: str, emit) -> None:
        super().__init__(emit)
        self.record, self._file = files.read_recording(folder, name)
        self.interp = ReplayEngine(self.record)
        self.repl = Repl(self.interp, stdin=io.StringIO(), stdout=Output(emit))
        self.length, self.program = len(self.record.get("steps", [])), self.record["program"].get("text")

    def scrub(self, n: int) -> None:
        n = max(0, min(int(n), self.length))
        with self._lock:
            self.repl.onecmd("reset")
            if n:
                self.repl.onecmd(f"step {n}")
            self.emit(self.snapshot())

    def details(self) -> dict:
        n, steps, images = self.interp.trace.total, self.record.get("steps", []), self.record.get("images", {})
        eye = next((base64.b64encode(images[s["eye"]]).decode() for s in reversed(steps[:n]) if s.get("eye") in images),
                   None)  # the last eye image recorded up to step n
        return dict(length=len(steps), waiting=False, board=None, eye=eye, breakpoints=[], outcome=None,
                    entry=f"{steps[n - 1]['state']}: {steps[n - 1]['text']}" if n else "")

    def close(self) -> None:
        self._file.close()


#: the page's messages to an open session: what each asks of it
COMMANDS = {
    "step": lambda s, doc: s.resume(f"step {int(doc.get('n', 1))}"),
    "run": lambda s, doc: s.resume("run"),
    "back": lambda s, doc: s.resume("back"),
    "reload": lambda s, doc: s.resume("reload"),
    "break": lambda s, doc: s.command(f"break {doc.get('state', '')}"),
    "clear": lambda s, doc: s.command(f"clear {doc.get('state', '')}"),
    "stop": lambda s, doc: s.stop(),
    "answer": lambda s, doc: s.answer(str(doc.get("text", ""))),
    "view": lambda s, doc: s.turn(float(doc.get("azimuth", 35))),
    "scrub": lambda s, doc: s.scrub(int(doc.get("n", 0))),
}


class RunSocket(JSONSocket):
    """``/ws/run``: one :class:`Session` per socket; its messages (and every error) go out in order
    through one queue, from whichever thread makes them."""

    async def on_connect(self, websocket: WebSocket) -> None:
        await websocket.accept()
        loop = asyncio.get_running_loop()
        self.session, self.folder = None, studio_of(websocket).folder  # Session | None; the studio's folder
        self.outbox: asyncio.Queue = asyncio.Queue()
        self.emit = lambda msg: loop.call_soon_threadsafe(self.outbox.put_nowait, msg)

        async def pump():
            while True:
                await websocket.send_text(json.dumps(await self.outbox.get()))

        self.pumping = asyncio.create_task(pump())

    async def on_message(self, websocket: WebSocket, doc: dict) -> None:
        cmd = doc.get("cmd")
        if cmd in ("start", "open"):
            await self._close()
            name = str(doc.get("path", ""))
            opening = (lambda: self._start(name, doc)) if cmd == "start" else (lambda: ReplaySession(self.folder, name, self.emit))
            self.session = await opened_in_thread(opening)  # the page gone meanwhile: closed, not left running
            self.emit(dict(type="fsm", graph=fsm_graph(self.session.interp.fsm), length=self.session.length,
                           program=self.session.program))
            self.emit(self.session.snapshot())
        elif cmd not in COMMANDS:
            raise InputError(f"unknown command {cmd!r}; expected start, open or {', '.join(COMMANDS)}")
        elif self.session is None:
            raise InputError("open a program (Run) or a recording first")
        else:
            await run_in_threadpool(COMMANDS[cmd], self.session, doc)

    def _start(self, name: str, doc: dict) -> RunSession:
        """A run of the program ``name`` (read once) with the given settings its world declares."""
        given = doc.get("settings") or {}  # a JSON object: the door's shape (schema.RUN) saw to it
        text, path = files.read_program(self.folder, name), inside(self.folder, name)  # path: its name and its imports' folder
        found = analyse(path, text, self.folder)
        settings = {str(k): str(v) for k, v in given.items() if k in found["settings"] and v}
        picture_file(self.folder, settings, found["image"])
        return RunSession(path, self.emit, backend=doc.get("backend") or None, settings=settings, folder=self.folder,
                          seed=int(doc.get("seed", 0)), robot=str(doc.get("robot") or "") or None, text=text)

    async def on_error(self, websocket: WebSocket, doc: dict, text: str) -> None:
        self.emit({"type": "error", "text": text})

    async def _close(self) -> None:
        if self.session is not None:
            session, self.session = self.session, None
            await run_in_threadpool(session.close)

    async def on_disconnect(self, websocket: WebSocket, close_code: int) -> None:
        self.pumping.cancel()
        await self._close()


async def _check(request: Request) -> Response:
    doc = await read_json(request)
    path = studio_of(request).path(str(doc.get("path") or "untitled.hila"))
    return JSONResponse(await run_in_threadpool(analyse, path, str(doc.get("text", "")), studio_of(request).folder))


PAGE = Page("run", "3 Run & watch", "run.js", routes=[
    Route("/api/check", _check, methods=["POST"]),
    Route("/api/plugins", lambda request: JSONResponse(plugins())),  # a plain function: run in a thread
    WebSocketRoute("/ws/run", RunSocket),
])
