"""The step loop: runs an FSM one state at a time over a world and a back end.

``Interpreter.step()`` executes the current state through its class's executor
(:mod:`hila_lang.engine.executors`; ``run`` states: :mod:`hila_lang.engine.run`) and returns a
:class:`~hila_lang.engine.trace.TraceEntry`; ``run(until=STATE)`` steps until the FSM ends or
is about to enter a breakpoint.  The values a state computes come from the run's
:class:`~hila_lang.engine.scene.Scene` (variables, point names, expressions).  The REPL
(:mod:`hila_lang.session.repl`) is a thin layer over this loop, as ``pdb`` sits on ``bdb``.

After each step the ``observers`` are called with its :class:`TraceEntry` (a recorder, a window's
state text).  Going back and reloading are :class:`~hila_lang.engine.history.History`'s.

Any hila error while a state runs (an unknown scene point, a question the world does not have
-- :class:`~hila_lang.core.errors.UnknownNameError` --, contradicted constraints, an unreachable
target) is a :class:`HilaRuntimeError` naming the state and the program line (exit status 1).
Any other exception raised by a world, a back end or OSILA is a bug and propagates unchanged
(the CLI reports it as an internal error, exit status 3).

Bounded and interruptible (see :meth:`Interpreter.step` and :meth:`Interpreter.run`):

- a failed or interrupted step is recorded in the trace too (its text says what happened), so a
  trace file of a failed run ends with the failing state; a back end that moved part of the way
  attaches that part to its error (``exc.executed``, (T', 3)) and the entry keeps it;
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

from typing import Any

import numpy as np

from ..core.errors import HilaError, HilaRuntimeError, InputError, Interrupted, StepLimitError
from ..core.interrupts import cause, exit_code, guarded
from ..language.fsm import FSM, RunState, SetState, State
from ..language.limits import DEFAULT_STEP_LIMIT, TRACE_KEEP
from ..language.source import source_line
from .executors import Context, Executor, executor
from .history import History, Snapshot
from .run import RunExecutor
from .scene import Scene
from .trace import Trace, TraceEntry

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
        #: the run's variables and names (:class:`~hila_lang.engine.scene.Scene`)
        self.scene = Scene(world, backend, fsm.points)
        self.context = Context(checked, self.scene, world, backend, self.osila_options, self._hold)
        self._executors: dict[type, Executor] = {}  # executor class -> its one object in this run
        self.history: list[Snapshot] | None = None  # see keep_history
        self._guard_now = None
        self.reset()
        self._tell_program()

    def _tell_program(self) -> None:
        """Tell the world what the program draws with: ``notify("program", marks=...)`` (see
        :mod:`hila_lang.engine.run`), when it draws at all.  A world that refuses one (an
        :class:`~hila_lang.core.errors.InputError`: a template that does not fit it) is told at
        the run statement that draws it (the first whose ``TEMPLATE.TAG`` the message names)."""
        states = [st for st in self.fsm.states.values() if isinstance(st, RunState) and st.pen_down]
        marks = {st.ref: self.runs.template(st) for st in states}
        if not marks:
            return
        try:
            self.world.notify("program", marks=marks)
        except InputError as exc:
            if exc.line is None:
                st = next((st for st in states if f"'{st.ref}'" in exc.message), states[0])
                exc.file, exc.line, exc.column = self.fsm.file, st.line, st.column
                exc.source_line = source_line(self.checked.program.source, st.line)
            raise

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Back to the start state with no variables; the hand back to ``hand at`` if given."""
        if self.history:  # the steps before a reset cannot be gone back to
            self._discard(self.history)
            self.history = []
        self.current: str = self.fsm.start
        self.scene.env = {}
        self.trace = Trace(self.trace_keep)
        self.last_run: TraceEntry | None = None
        self.last_path: np.ndarray | None = None
        self.last_icps: dict[str, np.ndarray] = {}
        self.done = False
        if self.fsm.hand is not None:
            state = SetState("<hand at>", line=self.fsm.hand.pos.line, column=self.fsm.hand.pos.column)
            self._guard(state, self._put_hand)  # a bad point or the back end's refusal names the line

    def _put_hand(self) -> None:
        self.backend.reset_hand(self.scene.point(self.fsm.hand))

    @property
    def state(self) -> State:
        return self.fsm.states[self.current]

    @property
    def env(self) -> dict[str, Any]:
        """The variables: slot -> value (the scene's)."""
        return self.scene.env

    @env.setter
    def env(self, value: dict[str, Any]) -> None:
        self.scene.env = value

    def hand(self) -> np.ndarray:
        return self.scene.hand()

    def executor_for(self, state: State) -> Executor:
        """The object that runs ``state`` in this run (its class's :func:`executor`)."""
        return self._executor(executor(state))

    def _executor(self, cls: type[Executor]) -> Executor:
        """This run's one object of executor class ``cls``, made when first needed."""
        if cls not in self._executors:
            self._executors[cls] = cls(self.context)
        return self._executors[cls]

    @property
    def runs(self) -> RunExecutor:
        """The executor of ``run`` states (bindings, constraints, explain)."""
        return self._executor(RunExecutor)

    def bind(self, st: RunState) -> dict[str, np.ndarray]:
        """The task ICPs run state ``st`` binds now (the REPL's ``icps``; a replay answers it too)."""
        return self.runs.bind(st)

    def _reloaded(self) -> None:
        """The program was replaced (:meth:`reload`): the executors and the scene see the new one."""
        self.context.checked, self.scene.points = self.checked, self.fsm.points
        for ex in self._executors.values():
            ex.reload()
        self._tell_program()

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
                    self._failed(state, f"failed: {exc.message}", exc.message, getattr(exc, "executed", None))
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

    def _failed(self, state: State, text: str, why: str, executed=None) -> None:
        """Record a failed or interrupted step; ``executed``: the part of a move the hand made before
        it stopped (a back end attaches it to its error: ``exc.executed``)."""
        executed = None if executed is None or len(executed) == 0 else np.asarray(executed, dtype=float)
        self._record(TraceEntry(self.trace.total + 1, state.name, state.kind, state.line,
                                text.splitlines()[0], None, executed=executed, error=why))

    def _interrupted(self, state: State, recorded: bool, stop: BaseException) -> Interrupted:
        if recorded:  # held until the step was recorded: it happened
            exc = _stopped_by(stop, "just after this state")
        else:
            exc = _stopped_by(stop, "before this state finished",
                              hint="if the program goes on ('step' or 'run' in hila repl), the state runs "
                                   "again from where the hand is")
            exc.executed = getattr(stop, "executed", None)  # what a move made before it was stopped
            self._failed(state, "interrupted", exc.message, exc.executed)
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
        """Run one state through its executor (:meth:`executor_for`); remembered for :meth:`back`
        when :meth:`keep_history` is on."""
        saved = self.snapshot() if self.history is not None else None
        try:
            entry = self.executor_for(st).execute(st, self.trace.total + 1)
        except BaseException:
            if saved is not None:
                self._discard([saved])
            raise
        if saved is not None:
            self._remember(saved)
        if entry.step_result is not None:  # a run: what the REPL's 'plot' and 'icps' show
            self.last_run, self.last_path, self.last_icps = entry, entry.path, entry.icps
        return entry

    def explain(self) -> list[str]:
        """What OSILA does in the current run state (before it runs), or did in the last run:
        lines of :func:`hila_lang.hierarchy.explain.explain_run` (ICP pairs, fallbacks, rounds and why)."""
        runs = self.runs
        if not self.done and isinstance(self.state, RunState):
            st = self.state
            where = f"{st.name} (line {st.line}), about to run"
            return self._guard(st, lambda: runs.explain(st, where))
        done = [t for t in self.trace if t.step_result is not None]
        if not done:
            raise HilaRuntimeError("nothing to explain yet: no run state is current or has run")
        last = done[-1]
        return runs.explain_done(self.fsm.states[last.state], last,
                                 title=f"{last.state} (line {last.line}), step {last.step}")


def _stopped_by(stop: BaseException, when: str, **kwargs) -> Interrupted:
    """The :class:`Interrupted` of a run ``stop`` ended (Ctrl-C: exit 130; SIGTERM: 143, ...)."""
    exc = Interrupted(f"interrupted ({cause(stop)}) {when}", **kwargs)
    exc.exit_code = exit_code(stop)
    return exc
