"""Run and watch: a program run (or a recording) driven through the REPL's own commands.

:class:`RunSession` builds the run exactly as ``hila repl`` does
(:func:`hila_lang.session.runner.prepare`, then :class:`hila_lang.session.repl.Repl`) and feeds
the page's buttons to ``Repl.onecmd`` -- ``step``, ``run``, ``break STATE``, ``back``,
``reload`` -- in a worker thread, one at a time.  A human opponent's cell comes from the page
(the world reads it from ``stdin``, :class:`LineInput`); ``stop`` quits a waiting game and
stops a running ``run`` before its next state (a breakpoint on every state).  After every step
the page gets the state, the trace line, the board and the left eye's image when the back end
has eyes.  :class:`ReplaySession` opens a ``.hilarec`` with
:class:`hila_lang.session.replay.ReplayEngine` under the same ``Repl``; scrubbing to step N is
``reset`` then ``step N``.
"""

from __future__ import annotations

import base64
import io
import queue
import tempfile
import threading
from pathlib import Path

from ..core.errors import HilaError


class LineInput(io.TextIOBase):
    """``stdin`` for a human opponent: ``readline`` waits for a line the page sends."""

    def __init__(self, on_wait) -> None:
        self._lines: queue.Queue[str] = queue.Queue()
        self.waiting = False
        self._on_wait = on_wait

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
        return True  # a person answers: the opponent does not echo the line


class Output(io.TextIOBase):
    """``stdout`` of the REPL and the world: each write goes to the page."""

    def __init__(self, emit) -> None:
        self._emit = emit

    def write(self, text: str) -> int:
        if text:
            self._emit({"type": "out", "text": text})
        return len(text)

    def flush(self) -> None:
        pass


def fsm_graph(fsm) -> dict:
    """Nodes and edges of the state machine, for drawing."""
    return dict(start=fsm.start,
                nodes=[dict(name=s.name, kind=s.kind, line=s.line) for s in fsm.states.values()],
                edges=[[s.name, target, label] for s in fsm.states.values() for target, label in s.edges()])


def _png(rgb) -> str:
    import cv2
    import numpy as np

    ok, png = cv2.imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
    return base64.b64encode(png.tobytes()).decode()


class _Session:
    def __init__(self, emit) -> None:
        self.emit = emit
        self.repl = None
        self._lock = threading.Lock()

    def command(self, line: str) -> None:
        """Run one REPL command in a worker thread (one at a time: a second waits its turn)."""
        def work():
            with self._lock:
                try:
                    self.repl.onecmd(line)
                except Exception as exc:  # noqa: BLE001 - reported on the page, the session goes on
                    self.emit({"type": "out", "text": f"error: {exc}\n"})
                self.emit(self.snapshot())
        threading.Thread(target=work, daemon=True).start()


class RunSession(_Session):
    """A program run on a back end, stepped by the page's buttons."""

    def __init__(self, program: Path, emit, *, backend: str | None = None, opponent: str | None = None,
                 seed: int = 0, robot: str | None = None) -> None:
        from ..session.repl import Repl
        from ..session.runner import prepare
        from ..plugins.options import RunOptions

        super().__init__(emit)
        self.stdin = LineInput(lambda: self.emit(self.snapshot()))
        self.stdout = Output(emit)
        self._out = tempfile.TemporaryDirectory(prefix="hila-studio-")
        settings = {"opponent": opponent} if opponent else {}
        if robot:  # --robot NAME (hila_lang.robot.spec): the 3-D view renders the arm that runs
            settings["robot"] = robot
        options = RunOptions(seed=seed, out=Path(self._out.name), settings=settings, stdin=self.stdin,
                             stdout=self.stdout)
        self.interp = prepare(program, options, backend)
        self.repl = Repl(self.interp, stdin=io.StringIO(), stdout=self.stdout)
        self.interp.observers.append(self._observe)
        self.last_eye: str | None = None
        self.azimuth = 35.0
        self.robot: str | None = None
        self._view()

    def _observe(self, entry) -> None:
        eyes = getattr(self.interp.backend, "eyes", None)
        if eyes is not None and entry.kind == "run":
            try:
                self.last_eye = _png(eyes.camera_image("left").rgb)
            except Exception:  # noqa: BLE001 - no picture is not a failed step
                self.last_eye = None
        if entry.kind == "run":
            self._view(entry)
        self.emit(dict(self.snapshot(), type="step", entry=str(entry)))

    def _view(self, entry=None) -> None:
        """The 3-D view (:mod:`.view3d`) now, with the last run state's planned and executed paths."""
        from .view3d import render

        entry = entry or self.interp.last_run
        try:
            rgb = render(self.interp.backend, self.azimuth, None if entry is None else entry.path,
                         None if entry is None else entry.executed)
        except Exception:  # noqa: BLE001 - no picture is not a failed step
            rgb = None
        self.robot = None if rgb is None else _png(rgb)

    def turn(self, azimuth: float) -> None:
        """Turn the 3-D view's camera to ``azimuth`` degrees and send the view again."""
        self.azimuth = float(azimuth) % 360.0
        with self._lock:
            self._view()
            self.emit(self.snapshot())

    def snapshot(self) -> dict:
        it = self.interp
        board = getattr(it.world, "board", None)
        path = it.last_path
        return dict(type="state", current=None if it.done else it.current, done=it.done,
                    steps=it.trace.total, waiting=self.stdin.waiting,
                    board=None if board is None else [str(c) for c in board],
                    path=None if path is None else path.tolist(), eye=self.last_eye, robot=self.robot,
                    arm=getattr(getattr(it.backend, "robot", None), "name", None),  # the robot that runs
                    breakpoints=list(self.repl.breakpoints) if self.repl else [])

    def move(self, cell: int) -> None:
        self.stdin.put(str(int(cell)))

    def stop(self) -> None:
        """Stop a run before its next state, and a game waiting for a move."""
        if "*" not in self.repl.breakpoints:
            self.repl.breakpoints.append("*")
        if self.stdin.waiting:
            self.stdin.put("q")

    def resume(self, line: str) -> None:
        if "*" in self.repl.breakpoints:
            self.repl.breakpoints.remove("*")
        self.command(line)

    def close(self) -> None:
        from ..session.runner import finish

        if self.stdin.waiting:
            self.stdin.put("q")
        with self._lock:
            try:
                finish(self.interp)
            except HilaError:
                pass
        self._out.cleanup()


class ReplaySession(_Session):
    """A recording (``.hilarec``), scrubbed step by step without a simulator."""

    def __init__(self, file: Path, emit) -> None:
        from ..session.recording import read_record
        from ..session.repl import Repl
        from ..session.replay import ReplayEngine

        super().__init__(emit)
        self.record = read_record(file)
        self.engine = ReplayEngine(self.record)
        self.interp = self.engine
        self.stdout = Output(emit)
        self.repl = Repl(self.engine, stdin=io.StringIO(), stdout=self.stdout)

    @property
    def length(self) -> int:
        return len(self.record.get("steps", []))

    def scrub(self, n: int) -> None:
        n = max(0, min(int(n), self.length))
        with self._lock:
            self.repl.onecmd("reset")
            if n:
                self.repl.onecmd(f"step {n}")
            self.emit(self.snapshot())

    def snapshot(self) -> dict:
        it = self.engine
        n = it.trace.total
        steps = self.record.get("steps", [])
        eye = None
        for s in reversed(steps[:n]):
            if s.get("eye") and s["eye"] in self.record.get("images", {}):
                eye = base64.b64encode(self.record["images"][s["eye"]]).decode()
                break
        path = it.last_path
        return dict(type="state", current=None if it.done else it.current, done=it.done, steps=n,
                    length=len(steps), waiting=False, board=None, eye=eye,
                    path=None if path is None else path.tolist(),
                    entry=str(steps[n - 1]["text"]) if n else "", breakpoints=[])

    def close(self) -> None:
        pass
