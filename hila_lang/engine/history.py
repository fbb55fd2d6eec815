"""Going back and reloading: the stepping engine's history (:class:`History`, mixed into
:class:`~hila_lang.engine.interpreter.Interpreter`).

With :meth:`History.keep_history` on (the REPL turns it on), every step is preceded by a
:class:`Snapshot` -- the interpreter's own state and the tokens of the world's and the back end's
``snapshots`` capability -- and :meth:`History.back` restores one.  :meth:`History.reload` swaps in
a newly checked program and goes on from the same state, or from where :func:`resume_at` says.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..core.errors import HilaRuntimeError
from ..language.fsm import FSM

#: how many steps the REPL's ``back`` can undo (older snapshots are discarded)
HISTORY_LIMIT = 100


@dataclass
class Snapshot:
    """What :meth:`History.back` restores: the interpreter's state and the world's and the
    back end's tokens (their ``snapshots`` capability)."""

    fsm: FSM
    current: str
    done: bool
    env: dict
    trace_length: int
    last_path: Any
    last_icps: dict
    world: Any
    backend: Any


def resume_at(old: FSM, new: FSM, current: str) -> tuple[str, str | None]:
    """Where a run at state ``current`` of ``old`` goes on in ``new``, and why when it is not the
    same state: the state of the same kind written at the same line and column (a renamed tag
    renames the state), else the first state after it (breadth first along the old transitions)
    that ``new`` still has, else the new start."""
    if current in new.states:
        return current, None
    was = old.states.get(current)
    if was is not None and was.line:
        same = [s.name for s in new.states.values()
                if (s.kind, s.line, s.column) == (was.kind, was.line, was.column)]
        if same:
            return same[0], f"state {current} is not in the program; {same[0]} is written where it was (line {was.line})"
    seen, todo = {current}, list(old.states[current].successors()) if current in old.states else []
    while todo:
        name = todo.pop(0)
        if name in seen:
            continue
        if name in new.states:
            return name, (f"state {current} is no longer in the program; {name} is the first state after it "
                          "that still is")
        seen.add(name)
        todo.extend(old.states[name].successors() if name in old.states else [])
    return new.start, f"state {current} is no longer in the program, nor any state after it: from the start"


class History:
    """The history methods of the interpreter (which has ``fsm``, ``checked``, ``world``,
    ``backend``, ``current``, ``done``, ``env``, ``trace``, ``last_path``, ``last_icps``)."""

    def keep_history(self, limit: int = HISTORY_LIMIT) -> str | None:
        """Remember the last ``limit`` steps for :meth:`back`.  Returns None, or why it cannot:
        the world or the back end has no ``snapshots`` capability."""
        missing = [f"{what} {name!r}" for what, name, obj in (("the world", self.fsm.world, self.world),
                                                              ("the back end", self.backend.name, self.backend))
                   if obj.snapshots is None]
        if missing:
            self.history = None
            self._no_history = f"{' and '.join(missing)} cannot go back (no snapshots capability)"
            return self._no_history
        self.history, self.history_limit = [], limit
        return None

    def snapshot(self) -> "Snapshot":
        """What the run is now: the interpreter's own state, the world's and the back end's."""
        return Snapshot(self.fsm, self.current, self.done, dict(self.env), len(self.trace), self.last_path,
                        dict(self.last_icps), self.world.snapshots.save(), self.backend.snapshots.save())

    def _remember(self, saved: "Snapshot") -> None:
        self.history.append(saved)
        if len(self.history) > self.history_limit:
            self._discard(self.history[:-self.history_limit])
            del self.history[:-self.history_limit]

    def _discard(self, snapshots) -> None:
        for snap in snapshots:
            self.world.snapshots.discard(snap.world)
            self.backend.snapshots.discard(snap.backend)

    def back(self, n: int = 1) -> str:
        """Undo the last ``n`` steps: the world, the back end (the simulator) and the interpreter
        are as they were before them.  Returns what it did, in words."""
        if self.history is None:
            raise HilaRuntimeError(getattr(self, "_no_history", "going back is off (keep_history)"))
        if not self.history:
            raise HilaRuntimeError("nothing to go back to: no step has run since the start (or the last reset)")
        if not 1 <= n <= len(self.history):
            raise HilaRuntimeError(f"can go back 1 to {len(self.history)} step(s), not {n}",
                                   hint=f"the last {self.history_limit} steps are kept" if len(self.history) ==
                                   self.history_limit else None)
        snap = self.history[-n]
        self.world.snapshots.restore(snap.world)
        self.backend.snapshots.restore(snap.backend)
        self._discard(self.history[-n:])
        del self.history[-n:]
        self.env, self.done = dict(snap.env), snap.done
        self.last_path, self.last_icps = snap.last_path, dict(snap.last_icps)
        del self.trace[snap.trace_length:]
        self.current, why = resume_at(snap.fsm, self.fsm, snap.current)
        return f"back {n} step{'s' if n > 1 else ''}: at {self.current}" + (f" ({why})" if why else "")

    def reload(self, checked, fsm: FSM) -> str:
        """Go on with a new version of the program (``checked``, ``fsm``) from the same state: the
        world, the back end, the variables and the trace stay.  Returns where it resumes and why."""
        if fsm.world != self.fsm.world:
            raise HilaRuntimeError(f"the program now names world '{fsm.world}', not '{self.fsm.world}': reload "
                                   "keeps the world and the back end", hint="start a new session for another world")
        old, self.checked, self.fsm = self.fsm, checked, fsm
        self._reloaded()
        if self.done:
            return "the program had finished; 'reset' runs the new one from its start"
        self.current, why = resume_at(old, fsm, self.current)
        return f"resuming at {self.current}" + (f": {why}" if why else " (the same state)")
