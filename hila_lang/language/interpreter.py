"""The stepping engine: runs an FSM one state at a time over a world and a back end.

``Interpreter.step()`` executes the current state and returns a :class:`TraceEntry`;
``run(until=STATE)`` steps until the FSM ends or is about to enter a breakpoint.  The REPL
(:mod:`hila_lang.language.repl`) is a thin layer over this engine, as ``pdb`` sits on ``bdb``.

A ``run`` state evaluates its bindings against the scene (variables, ``hand`` = where the back
end says the hand is, the program's ``point`` s, then the world's ``points()``), warps the
(sub-)template with :func:`hila_lang.hierarchy.step.hila_step` (the one HILA step, shared with
``hila imitate`` and ``hila eval --hila``: its ``start`` ICP bound to the hand unless the program
binds it), moves the back end along the path, and calls
``world.notify("state_done", state=, path=, executed=, kind="run", pen_down=, icps=, template=)``
(``template`` is the sub-template that ran).  Its ``via``/``avoid`` constraints (and those of the
task calls around it) are evaluated now (:meth:`Interpreter.constraints`: a point group gives one
per point) and go to OSILA's plan adjustment through the same step; the trace says how each was
met.

After each step the ``observers`` are called with its :class:`TraceEntry` (a recorder, a window's
state text).  Going back and reloading are :class:`~hila_lang.language.history.History`'s.

Any hila error while a state runs (an unknown scene point, a question the world does not have
-- :class:`~hila_lang.core.errors.UnknownNameError` --, contradicted constraints, an unreachable
target) is a :class:`HilaRuntimeError` naming the state and the program line (exit status 1).
Any other exception raised by a world, a back end or OSILA is a bug and propagates unchanged
(the CLI reports it as an internal error, exit status 3).

Bounded and interruptible (see :meth:`Interpreter.step` and :meth:`Interpreter.run`):

- a failed or interrupted step is recorded in the trace too (its text says what happened), so a
  trace file of a failed run ends with the failing state;
- memory stays flat however long a run is: :attr:`Interpreter.trace` keeps the newest
  :data:`TRACE_KEEP` entries (``len(trace)`` counts them all; ``observers`` see every entry as it
  is recorded, e.g. to stream a trace file);
- :meth:`Interpreter.run` stops a run after ``step_limit`` steps (default
  :data:`DEFAULT_STEP_LIMIT`) with :class:`~hila_lang.core.errors.StepLimitError`;
- Ctrl-C stops the current step (:class:`~hila_lang.core.errors.Interrupted`, exit status 130): while
  it computes or moves, at once (the state did not happen; ``step`` runs it again from where the
  hand is); once it has started changing the world, after it is recorded
  (:mod:`hila_lang.core.interrupts`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from . import ast as A
from ..core.bounded import BoundedLog
from ..core.errors import HilaError, HilaRuntimeError, Interrupted, StepLimitError, UnreachableError
from ..core.interrupts import guarded
from .fsm import FSM, BranchState, CallState, EndState, RunState, SetState, State, WaitState
from .history import History, Snapshot
from .limits import DEFAULT_STEP_LIMIT, TRACE_KEEP
from .parser import source_line

START, END = "start", "end"



@dataclass
class TraceEntry:
    """What one step did."""

    step: int
    state: str
    kind: str
    line: int
    text: str
    next: str | None
    path: np.ndarray | None = None
    executed: np.ndarray | None = None
    icps: dict[str, np.ndarray] = field(default_factory=dict)
    pen_down: bool | None = None
    value: Any = None
    #: the HILA step of a run state (:class:`hila_lang.hierarchy.step.Step`: OSILA's result, constraints)
    step_result: Any = None
    error: str | None = None  # why the step failed or stopped (its text says so too)

    def __str__(self) -> str:
        where = f"line {self.line}" if self.line else "-"
        return f"{self.step:>3}  {self.state}  [{where}]  {self.text}"


class Trace(BoundedLog):
    """The trace: the newest entries (:class:`~hila_lang.core.bounded.BoundedLog`), so a run of any
    length keeps memory flat.  ``total`` (= ``len()``) counts every entry recorded since the
    reset (the step number of the last one); ``kinds`` how many of each kind."""

    def __init__(self, keep: int = TRACE_KEEP) -> None:
        super().__init__(keep)
        self.kinds: dict[str, int] = {}

    @property
    def total(self) -> int:
        return len(self)

    def record(self, entry: "TraceEntry") -> None:
        self.append(entry)
        self.kinds[entry.kind] = self.kinds.get(entry.kind, 0) + 1

    def __delitem__(self, index) -> None:
        for entry in self.removed_after(index.start or 0) if isinstance(index, slice) else ():
            self.kinds[entry.kind] -= 1
        super().__delitem__(index)


def fmt_point(p) -> str:
    return "(" + ", ".join(f"{(0.0 if abs(v) < 5e-4 else v):.3f}" for v in np.asarray(p, float)) + ")"


def fmt_value(v) -> str:
    if isinstance(v, np.ndarray):
        return fmt_point(v)
    if isinstance(v, bool) or v is None:
        return {True: "true", False: "false", None: "none"}[v]
    if isinstance(v, float):
        return A._num(round(v, 6))
    if isinstance(v, str):
        return f'"{v}"'
    return repr(v)


#: state class -> its executor ``(interpreter, state, step number) -> TraceEntry``, found through the
#: state's class (:func:`executor`), never through a string
EXECUTORS: dict[type, Callable[..., "TraceEntry"]] = {}


def executes(state_class: type):
    """Decorator: ``fn`` executes the states of ``state_class`` (and of its subclasses that have
    no executor of their own)."""
    def add(fn):
        EXECUTORS[state_class] = fn
        return fn

    return add


def executor(state: State) -> Callable[..., "TraceEntry"]:
    """The executor of ``state``: its class's, else the nearest base class's."""
    for cls in type(state).__mro__:
        if cls in EXECUTORS:
            return EXECUTORS[cls]
    raise TypeError(f"no executor for the state class {type(state).__name__} (register one with @executes)")


class Interpreter(History):
    """Steps ``fsm`` (compiled from ``checked``) with ``world`` and ``backend``.

    Parameters
    ----------
    checked : CheckedProgram
        Gives the loaded templates and the program text (for error messages).
    fsm : FSM
    world : World
    backend : Backend
    osila_options : dict, optional
        Extra keyword options for :func:`hila_lang.osila.imitate`.
    step_limit : int, optional
        Most steps one :meth:`run` may take (None or 0: no limit); default
        :data:`DEFAULT_STEP_LIMIT`.
    trace_keep : int, optional
        Trace entries kept in memory (:class:`Trace`; 0: all of them); default :data:`TRACE_KEEP`.
    """

    def __init__(self, checked, fsm: FSM, world, backend, osila_options: dict | None = None, *,
                 step_limit: int | None = DEFAULT_STEP_LIMIT, trace_keep: int = TRACE_KEEP) -> None:
        self.checked, self.fsm, self.world, self.backend = checked, fsm, world, backend
        self.osila_options = dict(osila_options or {})
        self.step_limit = step_limit
        self.trace_keep = trace_keep
        #: called with every trace entry as it is recorded (failed and interrupted ones too)
        self.observers: list = []
        self._subs: dict[tuple[str, str | None], Any] = {}
        self._eval = _Eval(self)
        self.history: list[Snapshot] | None = None  # see keep_history
        self._guard_now = None
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Back to the start state with no variables; the hand back to ``hand at`` if given."""
        if self.history:  # the steps before a reset cannot be gone back to
            self._discard(self.history)
            self.history = []
        self.current: str = self.fsm.start
        self.env: dict[str, Any] = {}
        self.trace = Trace(self.trace_keep)
        self.last_run: TraceEntry | None = None
        self.last_path: np.ndarray | None = None
        self.last_icps: dict[str, np.ndarray] = {}
        self.done = False
        if self.fsm.hand is not None:
            state = SetState("<hand at>", line=self.fsm.hand.pos.line, column=self.fsm.hand.pos.column)
            self._guard(state, self._put_hand)  # a bad point or the back end's refusal names the line

    def _put_hand(self) -> None:
        self.backend.reset_hand(self.point(self.fsm.hand))

    @property
    def state(self) -> State:
        return self.fsm.states[self.current]

    def hand(self) -> np.ndarray:
        return np.asarray(self.backend.hand_position(), dtype=float)

    # ------------------------------------------------------------------ stepping
    def step(self) -> TraceEntry:
        """Execute the current state; return what it did.

        A state that fails is recorded (its entry's ``error`` says why) and its error raised;
        Ctrl-C raises :class:`~hila_lang.core.errors.Interrupted` (see the module docstring).
        """
        if self.done:
            raise HilaRuntimeError("the program has finished; 'reset' to run it again", state=self.current)
        state = self.state
        recorded = False
        try:
            with guarded() as guard:
                self._guard_now = guard
                try:
                    entry = self._guard(state, lambda: self._execute(state))
                except HilaRuntimeError as exc:
                    self._failed(state, f"failed: {exc.message}", exc.message)
                    raise
                guard.hold()  # a Ctrl-C from here on waits until the step is recorded
                self._record(entry)
                recorded = True
                if entry.next is None:
                    self.done = True
                else:
                    self.current = entry.next
        except KeyboardInterrupt as stop:
            raise self._interrupted(state, recorded, stop) from None
        finally:
            self._guard_now = None
        return entry

    def _hold(self) -> None:
        """Called by a state before it changes the world: Ctrl-C waits for the step to finish."""
        if self._guard_now is not None:
            self._guard_now.hold()

    def _record(self, entry: TraceEntry) -> None:
        self.trace.record(entry)
        for observer in self.observers:
            observer(entry)

    def _failed(self, state: State, text: str, why: str) -> None:
        self._record(TraceEntry(self.trace.total + 1, state.name, state.kind, state.line,
                                text.splitlines()[0], None, error=why))

    def _interrupted(self, state: State, recorded: bool, stop: BaseException) -> Interrupted:
        if recorded:  # held until the step was recorded: it happened
            exc = _stopped_by(stop, "just after this state")
        else:
            exc = _stopped_by(stop, "before this state finished",
                              hint="if the program goes on ('step' or 'run' in hila repl), the state runs "
                                   "again from where the hand is")
            self._failed(state, "interrupted", exc.message)
        return self._locate(exc, state)

    def run(self, until=None, max_steps: int | None = None, each=None) -> list[TraceEntry]:
        """Step until the end, ``max_steps`` steps, or just before entering a state ``until``
        (a state name, or a predicate on the name; not the state it starts at).

        ``each(entry)`` is called after every step.  Returns this call's entries (the newest
        :data:`TRACE_KEEP` when there are more).  More than ``step_limit`` steps raise
        :class:`~hila_lang.core.errors.StepLimitError` at the state the run has reached.
        """
        stop = until if callable(until) or until is None else (lambda name: name == until)
        done: list[TraceEntry] = []
        taken = 0
        try:
            while not self.done and (max_steps is None or taken < max_steps):
                if stop is not None and taken and stop(self.current):
                    break
                if self.step_limit and taken >= self.step_limit:
                    raise self._locate(StepLimitError(
                        f"stopped after {taken} steps without finishing (the step limit)",
                        hint="a loop that never ends? raise the limit with --max-steps N (0 for none)"), self.state)
                entry = self.step()
                taken += 1
                done.append(entry)
                if self.trace_keep and len(done) >= 2 * self.trace_keep:
                    del done[: len(done) - self.trace_keep]
                if each is not None:
                    each(entry)
        except KeyboardInterrupt as stop:  # between two steps (inside one, step() raises Interrupted)
            raise self._locate(_stopped_by(stop, "between two states"), self.state) from None
        return done

    def _guard(self, state: State, action):
        try:
            return action()
        except HilaRuntimeError as exc:
            raise self._locate(exc, state) from None
        except HilaError as exc:  # bad input met while running (e.g. OSILA's InputError)
            raise self._locate(HilaRuntimeError(exc.message, hint=exc.hint), state) from None
        # anything else (KeyError, TypeError, ... from a world, a back end or OSILA) is a bug:
        # it propagates, and the CLI reports an internal error (exit 3)

    def _locate(self, exc: HilaRuntimeError, state: State) -> HilaRuntimeError:
        if exc.state is None and not state.name.startswith("<"):
            exc.state = state.name
        if exc.line is None and state.line:
            exc.file = self.fsm.file
            exc.line, exc.column = state.line, state.column
            exc.source_line = source_line(self.checked.program.source, state.line)
        return exc

    def _execute(self, st: State) -> TraceEntry:
        """Run one state: its class's :func:`executor` ``(self, state, step number)``; remembered
        for :meth:`back` when :meth:`keep_history` is on."""
        saved = self.snapshot() if self.history is not None else None
        try:
            entry = executor(st)(self, st, self.trace.total + 1)
        except BaseException:
            if saved is not None:
                self._discard([saved])
            raise
        if saved is not None:
            self._remember(saved)
        return entry

    @executes(SetState)
    def exec_set(self, st, n: int) -> TraceEntry:
        return self._assign(st, n, "set ")

    @executes(CallState)
    def exec_call(self, st, n: int) -> TraceEntry:
        return self._assign(st, n, "call " + st.task + (": " if st.assign else ""))

    def _assign(self, st, n: int, head: str) -> TraceEntry:
        values = [(slot, self.eval(e)) for slot, e in st.assign]
        self._hold()
        self.env.update(values)
        text = head + ", ".join(f"{slot.rsplit(':', 1)[1]} = {fmt_value(v)}" for slot, v in values)
        return TraceEntry(n, st.name, st.kind, st.line, text, st.next)

    @executes(WaitState)
    def exec_wait(self, st, n: int) -> TraceEntry:
        args = [self.eval(a) for a in st.args]
        value = _plain(self.world.wait(st.event, *args))
        self._hold()
        if st.into:
            self.env[st.into] = value
        text = f"wait {st.event} -> {fmt_value(value)}"
        return TraceEntry(n, st.name, st.kind, st.line, text, st.next, value=value)

    @executes(BranchState)
    def exec_branch(self, st, n: int) -> TraceEntry:
        value = self.eval(st.guard)
        if not isinstance(value, (bool, np.bool_)):
            raise HilaRuntimeError(f"a condition must be true or false, got {fmt_value(value)} "
                                   f"from '{_src(st.guard)}'")
        nxt = st.then if value else st.orelse
        text = f"{_src(st.guard)}: {fmt_value(bool(value))} -> {nxt}"
        return TraceEntry(n, st.name, st.kind, st.line, text, nxt, value=bool(value))

    @executes(EndState)
    def exec_end(self, st, n: int) -> TraceEntry:
        self._hold()
        self.world.notify("program_done")
        return TraceEntry(n, st.name, "end", st.line, "end", None)

    # ------------------------------------------------------------------ run states
    def template(self, st: State):
        key = (st.template, st.tag)
        if key not in self._subs:
            t = self.checked.templates[st.template]
            self._subs[key] = t if st.tag is None else t.sub(st.tag)
        return self._subs[key]

    def scene_binding(self, st) -> dict[str, np.ndarray | None]:
        """What a run state's bindings say now: ICP name -> point, or None (``icp = none``).

        ``start`` appears only when the program binds it; :func:`hila_lang.hierarchy.step.hila_step`
        binds it to the hand otherwise.
        """
        t = self.template(st)
        scene = [k for k in t.icps if k not in (START, END)]
        out: dict[str, np.ndarray | None] = {}
        spread = None
        for icp, expr in st.bindings:
            if icp == A.SPREAD:
                spread = expr
            elif icp in t.icps:
                out[icp] = self.point(expr, allow_none=True)
            else:  # a group prefix: icp.K <- value.K
                prefix = self.reference(expr)
                for k in t.icps:
                    if k.startswith(icp + "."):
                        out[k] = self.lookup(f"{prefix}.{k[len(icp) + 1:]}")
        if spread is not None:
            prefix = self.reference(spread)
            for k in scene:
                if k not in out:
                    out[k] = self.lookup(f"{prefix}.{k}")
        return out

    def bind(self, st) -> dict[str, np.ndarray]:
        """Task ICPs of a run state: name -> point (3,), in the template's ICP order (a 2-D
        template's as bound in the scene, before they are projected onto the drawing surface)."""
        from ..hierarchy.step import bind

        t, binding = self.template(st), self.scene_binding(st)
        if t.dim == 2 and self.surface() is not None:
            given = {START: self.hand(), **binding}
            return {k: given[k] for k in t.icps if given.get(k) is not None}
        return bind(t, binding, self.hand())

    def surface(self):
        """The world's drawing surface (its scene's), where 2-D templates run; or None."""
        scene = self.world.scene
        return None if scene is None else scene.surface

    @executes(RunState)
    def exec_run(self, st, n: int) -> TraceEntry:
        from ..hierarchy.step import hila_step

        t = self.template(st)
        step = hila_step(t, self.scene_binding(st), self.hand(), constraints=self.constraints(st),
                         surface=self.surface(), **self.osila_options)
        path, icps = step.path, step.icps
        try:
            executed = self.backend.move(path, pen_down=bool(st.pen_down), label=st.name)
        except UnreachableError as exc:  # told as the program's target, not a waypoint index
            from ..robot.reach import name_the_target

            raise name_the_target(exc, icps, st.ref) from None
        executed = None if executed is None else np.asarray(executed, dtype=float)
        self._hold()
        self.last_path, self.last_icps = path, icps
        self.world.notify("state_done", state=st.name, path=path, executed=executed, kind="run",
                          pen_down=bool(st.pen_down), icps=dict(icps), template=t)
        text = (f"run {st.ref} pen {'down' if st.pen_down else 'up'}: {len(path)} points "
                f"{fmt_point(path[0])} -> {fmt_point(path[-1])}; icps "
                + " ".join(f"{k}={fmt_point(v)}" for k, v in icps.items()) + met_text(step))
        text += "".join(f"; note: {n}" for n in step.notes)
        self.last_run = TraceEntry(n, st.name, "run", st.line, text, st.next, path=path, executed=executed,
                                   icps=icps, pen_down=bool(st.pen_down), step_result=step)
        return self.last_run

    def explain(self) -> list[str]:
        """What OSILA does in the current run state (before it runs), or did in the last run:
        lines of :func:`hila_lang.hierarchy.explain.explain_run` (ICP pairs, fallbacks, rounds and why)."""
        from ..hierarchy.explain import explain_run, explain_step

        if not self.done and self.state.kind == "run":
            st = self.state
            where = f"{st.name} (line {st.line}), about to run"
            return self._guard(st, lambda: explain_run(
                self.template(st), self.scene_binding(st), self.hand(), self.constraints(st), self.osila_options,
                surface=self.surface(), title=where))
        done = [t for t in self.trace if t.step_result is not None]
        if not done:
            raise HilaRuntimeError("nothing to explain yet: no run state is current or has run")
        last = done[-1]
        return explain_step(self.template(self.fsm.states[last.state]), last.step_result,
                            title=f"{last.state} (line {last.line}), step {last.step}")

    # ------------------------------------------------------------------ constraints
    def constraints(self, st) -> list:
        """A run state's ``via``/``avoid`` as named :class:`hila_lang.hierarchy.step.Constraint` s, now:
        a point group gives one per point; a radius must be a number > 0 (metres)."""
        from ..hierarchy.step import Constraint

        out = []
        for c in st.constraints:
            where = f"{c.text()} at {c.pos.line}:{c.pos.column}" if c.pos.line else c.text()
            radius = None
            if c.radius is not None:
                radius = self.eval(c.radius)
                if isinstance(radius, bool) or not isinstance(radius, (int, float)) or not radius > 0:
                    raise HilaRuntimeError(f"an obstacle's radius must be a number of metres > 0, got "
                                           f"{fmt_value(radius)} from '{_src(c.radius)}' in '{where}'")
            for member, point in self.points_of(c.value):
                name = where if member is None else f"{where} ({member})"
                out.append(Constraint(point, None if radius is None else float(radius), name))
        return out

    def points_of(self, expr) -> list[tuple[str | None, np.ndarray]]:
        """A point (``[(None, p)]``) or every point of a group (``[(name, p), ...]``, scene order)."""
        value = self.eval(expr)
        if isinstance(value, str):
            value = self.lookup(value)
        if isinstance(value, np.ndarray) and value.shape in ((2,), (3,)):
            return [(None, value)]
        if isinstance(value, str):  # a group prefix: its points, the world's then the program's
            scene = self.scene_points()
            members = [(k, np.asarray(p, dtype=float)) for k, p in scene.items() if k.startswith(value + ".")]
            if members:
                return members
        raise HilaRuntimeError(f"expected a point or a point group, got {fmt_value(value)} from '{_src(expr)}'")

    # ------------------------------------------------------------------ expressions
    def scene_points(self) -> dict[str, np.ndarray]:
        pts = dict(self.world.points())
        for name, expr in self.fsm.points.items():
            pts[name] = self.point(expr)
        return pts

    def lookup(self, name: str, points: dict | None = None):
        """A scene point by full name -> (3,); a group prefix -> its name (str)."""
        if name == "hand":
            return self.hand()
        if name.startswith("hand.") and name[5:] in ("x", "y", "z"):
            return float(self.hand()["xyz".index(name[5:])])
        if name in self.fsm.points:
            return self.point(self.fsm.points[name])
        points = self.world.points() if points is None else points
        if name in points:  # None: a point the world knows of but does not see now (binds an ICP to none)
            return None if points[name] is None else np.asarray(points[name], dtype=float)
        if any(k.startswith(name + ".") for k in points) or any(k.startswith(name + ".") for k in self.fsm.points):
            return name
        head, _, attr = name.rpartition(".")
        if attr in ("x", "y", "z") and head:
            base = self.lookup(head, points)
            if isinstance(base, np.ndarray):
                return float(base["xyz".index(attr)])
        import difflib

        close = difflib.get_close_matches(name, list(points) + list(self.fsm.points), n=1)
        raise HilaRuntimeError(f"unknown scene point '{name}'",
                               hint=f"did you mean '{close[0]}'?" if close else
                               f"the world has {len(points)} named point(s)")

    def reference(self, expr) -> str:
        """The dotted name an expression refers to (for ``c.*`` and group bindings)."""
        if isinstance(expr, A.Name):
            return expr.text
        value = self.eval(expr)
        if isinstance(value, str):
            return value
        raise HilaRuntimeError(f"expected the name of a point group, got {fmt_value(value)} "
                               f"from '{_src(expr)}'")

    def point(self, expr, allow_none: bool = False):
        value = self.eval(expr)
        if value is None and allow_none:
            return None
        if isinstance(value, str):
            value = self.lookup(value)
        if isinstance(value, np.ndarray) and value.shape in ((3,), (2,)):
            return value
        raise HilaRuntimeError(f"expected a point, got {fmt_value(value)} from '{_src(expr)}'")

    def eval(self, e) -> Any:
        """The value of expression ``e`` now (see :class:`_Eval`)."""
        return self._eval.visit(e)


class _Eval(A.Visitor):
    """Expression evaluation against an interpreter's variables, scene and world."""

    def __init__(self, interp: "Interpreter") -> None:
        self.it = interp

    def generic_visit(self, e):  # pragma: no cover - every expression has its method
        raise HilaRuntimeError(f"cannot evaluate {e!r}")

    def visit_Number(self, e):
        return e.value

    visit_String = visit_Bool = visit_Number

    def visit_NoneLit(self, e):
        return None

    def visit_Var(self, e):
        env = self.it.env
        if e.slot not in env:
            name = e.slot.rsplit(":", 1)[1]
            raise HilaRuntimeError(f"'{name}' has no value yet (its 'let' has not run)")
        value = env[e.slot]
        for attr in e.attrs:
            value = self._attr(value, attr)
        return value

    def visit_Name(self, e):
        return self.it.lookup(e.text)

    def visit_Vector(self, e):
        items = [self.visit(i) for i in e.items]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in items):
            raise HilaRuntimeError(f"a point's coordinates must be numbers in '{_src(e)}'")
        return np.array(items, dtype=float)

    def visit_Unary(self, e):
        v = self.visit(e.operand)
        if e.op == "not":
            return not self._bool(v, e.operand)
        return -self._number_or_point(v, e)

    def visit_Ask(self, e):
        args = [self.visit(a) for a in e.args]
        return _plain(self.it.world.query(e.name, *args))

    def _attr(self, value, attr: str):
        if isinstance(value, str):
            return self.it.lookup(f"{value}.{attr}")
        if isinstance(value, np.ndarray) and attr in ("x", "y", "z") and value.shape[0] > "xyz".index(attr):
            return float(value["xyz".index(attr)])
        raise HilaRuntimeError(f"{fmt_value(value)} has no part '.{attr}'")

    def _bool(self, v, expr) -> bool:
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        raise HilaRuntimeError(f"expected true or false, got {fmt_value(v)} from '{_src(expr)}'")

    def _number_or_point(self, v, expr):
        if isinstance(v, str):
            v = self.it.lookup(v)
        if isinstance(v, (int, float, np.ndarray)) and not isinstance(v, bool):
            return v
        raise HilaRuntimeError(f"expected a number or a point, got {fmt_value(v)} in '{_src(expr)}'")

    def visit_Binary(self, e: A.Binary):
        if e.op in ("and", "or"):
            left = self._bool(self.visit(e.left), e.left)
            if (e.op == "and" and not left) or (e.op == "or" and left):
                return left
            return self._bool(self.visit(e.right), e.right)
        a, b = self.visit(e.left), self.visit(e.right)
        if e.op in ("==", "!="):
            same = _equal(a, b)
            return same if e.op == "==" else not same
        if e.op == "+" and (isinstance(a, str) or isinstance(b, str)):
            return _text(a) + _text(b)
        a, b = self._number_or_point(a, e.left), self._number_or_point(b, e.right)
        if e.op in ("<", "<=", ">", ">="):
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                raise HilaRuntimeError(f"cannot order points in '{_src(e)}'")
            return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b}[e.op]
        if e.op == "/" and not isinstance(b, np.ndarray) and b == 0:
            raise HilaRuntimeError(f"division by zero in '{_src(e)}'")
        if isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape != b.shape:
            raise HilaRuntimeError(f"points of different sizes in '{_src(e)}'")
        return {"+": lambda: a + b, "-": lambda: a - b, "*": lambda: a * b, "/": lambda: a / b}[e.op]()


_src = A.source_text  # an expression as the user wrote it (variables by name, not by slot)


def met_text(step) -> str:
    """How a run's route met its constraints, for the trace: ``; via w at 5:9 met at 0.4 mm``."""
    parts = []
    for c, value in step.met():
        if c.radius is None:
            parts.append(f"{c.name} met at {value * 1000:.1f} mm")
        else:
            parts.append(f"{c.name} cleared by {value * 1000:.1f} mm")
    return "".join(f"; {p}" for p in parts)


def _plain(value):
    """World answers as hila values: numpy scalars -> Python, sequences of 2-3 numbers -> points."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)) and len(value) in (2, 3) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return np.asarray(value, dtype=float)
    return value


def _text(v) -> str:
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    return v if isinstance(v, str) else fmt_value(v)


def _equal(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape and bool(np.allclose(a, b))
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b or (isinstance(a, bool) and isinstance(b, bool) and a == b)
    return a == b


def _stopped_by(stop: BaseException, when: str, **kwargs) -> Interrupted:
    """The :class:`Interrupted` of a run ``stop`` ended (Ctrl-C: exit 130; SIGTERM: 143, ...)."""
    from ..core.interrupts import cause, exit_code

    exc = Interrupted(f"interrupted ({cause(stop)}) {when}", **kwargs)
    exc.exit_code = exit_code(stop)
    return exc
