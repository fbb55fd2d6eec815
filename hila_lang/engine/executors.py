"""One executor per state class: what a state of that class does when the step loop reaches it.

An executor is an object made once per run (:class:`Executor`, holding the run's
:class:`Context`); ``execute(state, n)`` does the state and returns its
:class:`~hila_lang.engine.trace.TraceEntry`.  It is found through the state's class
(:func:`executor`: the class's own, else its nearest base's), never through a string.  A new
state kind is a :class:`~hila_lang.language.fsm.State` subclass and one class here (or in a
module of its own, like :mod:`hila_lang.engine.run`) decorated ``@executes(TheState)``.

Before an executor changes the world it calls ``ctx.hold()``: from then on Ctrl-C waits until
the step is recorded (:mod:`hila_lang.core.interrupts`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..core.errors import HilaRuntimeError
from ..language.fsm import BranchState, CallState, EndState, SetState, State, WaitState
from .scene import Scene, plain, src
from .trace import TraceEntry, fmt_value


@dataclass
class Context:
    """What an executor may use: the checked program (its templates), the scene (variables and
    values), the world, the back end, OSILA's options, and ``hold`` (see the module docstring)."""

    checked: Any
    scene: Scene
    world: Any
    backend: Any
    osila_options: dict
    hold: Callable[[], None]


class Executor:
    """Runs the states of one class (see :func:`executes`)."""

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx

    def execute(self, st: State, n: int) -> TraceEntry:
        """Do state ``st`` as step ``n``; return what it did."""
        raise NotImplementedError

    def reload(self) -> None:
        """The program was replaced (``ctx.checked`` is the new one): drop what came from the old."""


#: state class -> the executor class that runs its states (:func:`executes`)
EXECUTORS: dict[type, type[Executor]] = {}


def executes(state_class: type):
    """Class decorator: the executor runs the states of ``state_class`` (and of its subclasses
    that have no executor of their own)."""
    def add(cls):
        EXECUTORS[state_class] = cls
        return cls

    return add


def executor(state: State) -> type[Executor]:
    """The executor class of ``state``: its class's, else the nearest base class's."""
    for cls in type(state).__mro__:
        if cls in EXECUTORS:
            return EXECUTORS[cls]
    raise TypeError(f"no executor for the state class {type(state).__name__} (register one with @executes)")


@executes(SetState)
class SetExecutor(Executor):
    """``let`` and loop counters: every slot gets its value, all computed first."""

    def head(self, st) -> str:
        return "set "

    def execute(self, st, n: int) -> TraceEntry:
        scene = self.ctx.scene
        values = [(slot, scene.eval(e)) for slot, e in st.assign]
        self.ctx.hold()
        scene.env.update(values)
        text = self.head(st) + ", ".join(f"{slot.rsplit(':', 1)[1]} = {fmt_value(v)}" for slot, v in values)
        return TraceEntry(n, st.name, st.kind, st.line, text, st.next)


@executes(CallState)
class CallExecutor(SetExecutor):
    """Entering a task: its parameters are set as a ``let`` sets its name."""

    def head(self, st) -> str:
        return "call " + st.task + (": " if st.assign else "")


@executes(WaitState)
class WaitExecutor(Executor):
    """``wait EVENT(args)``: the world blocks until the event; its value goes to ``into``."""

    def execute(self, st, n: int) -> TraceEntry:
        scene = self.ctx.scene
        args = [scene.eval(a) for a in st.args]
        value = plain(self.ctx.world.wait(st.event, *args))
        self.ctx.hold()
        if st.into:
            scene.env[st.into] = value
        return TraceEntry(n, st.name, st.kind, st.line, f"wait {st.event} -> {fmt_value(value)}", st.next,
                          value=value)


@executes(BranchState)
class BranchExecutor(Executor):
    """``if`` / ``while`` / ``until`` / ``repeat``'s test: true goes to ``then``, false to ``orelse``."""

    def execute(self, st, n: int) -> TraceEntry:
        value = self.ctx.scene.eval(st.guard)
        if not isinstance(value, (bool, np.bool_)):
            raise HilaRuntimeError(f"a condition must be true or false, got {fmt_value(value)} "
                                   f"from '{src(st.guard)}'")
        nxt = st.then if value else st.orelse
        return TraceEntry(n, st.name, st.kind, st.line, f"{src(st.guard)}: {fmt_value(bool(value))} -> {nxt}", nxt,
                          value=bool(value))


@executes(EndState)
class EndExecutor(Executor):
    """The program is done: the world is told (``program_done``)."""

    def execute(self, st, n: int) -> TraceEntry:
        self.ctx.hold()
        self.ctx.world.notify("program_done")
        return TraceEntry(n, st.name, "end", st.line, "end", None)
