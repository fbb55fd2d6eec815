"""Checked program -> :class:`~hila_lang.language.fsm.FSM`.

Tasks are compiled inline: each call site becomes a ``call`` state that binds the parameters
(slots ``PREFIX:NAME``), followed by the task's body under the prefix ``PREFIX/TASK``.  A run,
call, let or wait whose base name occurs more than once in one body gets ``#k`` (``a#1``,
``a#2``); control states are always numbered (``if#1``, ``while#2``, ``repeat#1``).  Variables
are scoped per task instance: ``let`` binds a slot visible to the rest of that body.

After building, every state must be reachable from the start (constant ``true``/``false``
guards prune an edge); an unreachable statement is a :class:`CheckError` at its line.
"""

from __future__ import annotations

from collections import Counter, deque

from . import ast as A
from ..core.errors import CheckError
from .checker import CheckedProgram
from .fsm import (END_STATE, FSM, TRACK_BLEND, TRACK_EVERY, TRACK_THRESHOLD, BranchState, CallState, EndState,
                  RunState, SetState, State, Tracking, WaitState)
from .source import source_line


def _base(s) -> str | None:
    """The name a statement's state is counted under (``#k`` numbering), or None."""
    if isinstance(s, A.RunStmt):
        return s.tag or s.template
    if isinstance(s, A.CallStmt):
        return s.task
    if isinstance(s, A.LetStmt):
        return "let"
    if isinstance(s, A.WaitStmt):
        return "wait"
    return None


class _Scope:
    """Names and counters of one task instance."""

    def __init__(self, prefix: str, body, params: dict[str, str], inherited: tuple = ()) -> None:
        self.prefix = prefix
        self.vars = dict(params)  # name -> slot
        self.inherited = inherited  # constraints of the task calls around this body, resolved
        self.totals = Counter(b for b in map(_base, A.walk(body)) if b is not None)
        self.used: Counter = Counter()

    def name(self, base: str, always_number: bool = False) -> str:
        self.used[base] += 1
        if always_number or base in ("let", "wait") or self.totals[base] > 1:
            return f"{self.prefix}/{base}#{self.used[base]}"
        return f"{self.prefix}/{base}"

    def resolve(self, e):
        """Replace variable names by :class:`~hila_lang.language.ast.Var` slots."""
        return A.map_names(e, lambda n: A.Var(self.vars[n.parts[0]], n.parts[1:], n.pos) if n.parts[0] in self.vars else n)

    def constraints(self, constraints) -> tuple:
        """The constraints around this body, then ``constraints`` resolved here."""
        return self.inherited + tuple(
            A.Constraint(c.kind, self.resolve(c.value), None if c.radius is None else self.resolve(c.radius), c.pos)
            for c in constraints)


def _tracking(track: A.Track, scope: _Scope) -> Tracking:
    """A run's ``track`` clause as the FSM keeps it: names resolved, SI units, defaults filled in."""
    given = {o.kind: o.value / 1000.0 for o in track.options}  # ms -> s, mm -> m
    return Tracking(tuple(scope.resolve(n) for n in track.names), given.get("every", TRACK_EVERY),
                    given.get("threshold", TRACK_THRESHOLD), given.get("blend", TRACK_BLEND), given.get("lift"))


class _Compiler(A.Visitor):
    """``visit(stmt, scope)`` compiles one statement: returns (entry state name or None, dangling
    [(state, attribute)] that the next statement's entry completes)."""

    def __init__(self, checked: CheckedProgram) -> None:
        self.c = checked
        self.states: dict[str, State] = {}

    def add(self, state: State, pos: A.Pos) -> State:
        state.line, state.column = pos.line, pos.column
        self.states[state.name] = state
        return state

    def block(self, body, scope: _Scope):
        """Compile ``body``; return (entry name or None, dangling [(state, attribute)])."""
        entry, dangling = None, []
        for s in body:
            e, d = self.visit(s, scope)
            if e is None:
                continue
            for st, attr in dangling:
                setattr(st, attr, e)
            entry = entry or e
            dangling = d
        return entry, dangling

    def generic_visit(self, s, scope):  # pragma: no cover - every statement has its method
        raise TypeError(f"unknown statement {s!r}")

    def visit_RunStmt(self, s: A.RunStmt, scope: _Scope):
        template = self.c.templates[s.template]
        if s.pen is not None:
            pen = s.pen == "down"
        elif s.tag is not None:
            pen = bool(template.segment(s.tag).contact)
        else:
            pen = any(seg.contact for seg in template.segments)
        st = self.add(RunState(scope.name(s.tag or s.template), template=s.template, tag=s.tag,
                               bindings=tuple((b.icp, scope.resolve(b.value)) for b in s.bindings),
                               pen_down=pen, constraints=scope.constraints(s.constraints),
                               track=None if s.track is None else _tracking(s.track, scope)), s.pos)
        return st.name, [(st, "next")]

    def visit_CallStmt(self, s: A.CallStmt, scope: _Scope):
        name = scope.name(s.task)
        task = self.c.tasks[s.task]
        slots = {p: f"{name}:{p}" for p in task.params}
        st = self.add(CallState(name, task=s.task,
                                assign=tuple((slots[p], scope.resolve(a)) for p, a in zip(task.params, s.args))), s.pos)
        entry, dangling = self.block(task.body, _Scope(name, task.body, slots, scope.constraints(s.constraints)))
        if entry is None:
            return st.name, [(st, "next")]
        st.next = entry
        return st.name, dangling

    def visit_LetStmt(self, s: A.LetStmt, scope: _Scope):
        name = scope.name("let")
        slot = f"{scope.prefix}:{s.name}"
        if isinstance(s.value, A.Wait):
            st = self.add(WaitState(name, event=s.value.event, args=tuple(scope.resolve(a) for a in s.value.args),
                                    into=slot), s.pos)
        else:
            st = self.add(SetState(name, assign=((slot, scope.resolve(s.value)),)), s.pos)
        scope.vars[s.name] = slot
        return st.name, [(st, "next")]

    def visit_WaitStmt(self, s: A.WaitStmt, scope: _Scope):
        st = self.add(WaitState(scope.name("wait"), event=s.wait.event,
                                args=tuple(scope.resolve(a) for a in s.wait.args)), s.pos)
        return st.name, [(st, "next")]

    def visit_IfStmt(self, s: A.IfStmt, scope: _Scope):
        base = scope.name("if", True)
        first, dangling, prev = None, [], None
        for i, (cond, body) in enumerate(s.branches):
            name = base if i == 0 else f"{base}/elif#{i}"
            st = self.add(BranchState(name, guard=scope.resolve(cond)), cond.pos if i else s.pos)
            if prev is not None:
                prev.orelse = st.name
            first = first or st.name
            entry, d = self.block(body, scope)
            if entry is None:
                dangling.append((st, "then"))
            else:
                st.then = entry
            dangling += d
            prev = st
        if s.orelse is not None:
            entry, d = self.block(s.orelse, scope)
            if entry is None:
                dangling.append((prev, "orelse"))
            else:
                prev.orelse = entry
            dangling += d
        else:
            dangling.append((prev, "orelse"))
        return first, dangling

    def _loop(self, s, scope: _Scope, word: str, loop_attr: str, exit_attr: str):
        st = self.add(BranchState(scope.name(word, True), guard=scope.resolve(s.cond)), s.pos)
        entry, d = self.block(s.body, scope)
        setattr(st, loop_attr, entry or st.name)
        for x, attr in d:
            setattr(x, attr, st.name)
        return st.name, [(st, exit_attr)]

    def visit_WhileStmt(self, s: A.WhileStmt, scope: _Scope):
        return self._loop(s, scope, "while", "then", "orelse")

    def visit_UntilStmt(self, s: A.UntilStmt, scope: _Scope):
        return self._loop(s, scope, "until", "orelse", "then")

    def visit_RepeatStmt(self, s: A.RepeatStmt, scope: _Scope):
        name = scope.name("repeat", True)
        slot = f"{scope.prefix}:{name.rsplit('/', 1)[1]}"
        counter = A.Var(slot, (), s.pos)
        init = self.add(SetState(name, assign=((slot, scope.resolve(s.count)),)), s.pos)
        test = self.add(BranchState(f"{name}/loop", guard=A.Binary(">", counter, A.Number(0.0))), s.pos)
        init.next = test.name
        dec = SetState(f"{name}/next", next=test.name, assign=((slot, A.Binary("-", counter, A.Number(1.0))),))
        entry, d = self.block(s.body, scope)
        self.add(dec, s.pos)
        test.then = entry or dec.name
        for x, attr in d:
            setattr(x, attr, dec.name)
        return init.name, [(test, "orelse")]

    def build(self) -> FSM:
        scope = _Scope("main", self.c.main.body, {})
        entry, dangling = self.block(self.c.main.body, scope)
        end = EndState(END_STATE)
        self.states[END_STATE] = end
        for st, attr in dangling:
            setattr(st, attr, END_STATE)
        fsm = FSM(self.c.program.file, self.c.world, entry or END_STATE, self.states,
                  {i.alias: i.source for i in self.c.program.of(A.ImportDecl)}, dict(self.c.points), self.c.hand)
        self.reachability(fsm)
        return fsm

    def reachability(self, fsm: FSM) -> None:
        seen, todo = {fsm.start}, deque([fsm.start])
        while todo:
            st = fsm.states[todo.popleft()]
            nexts = st.successors()
            if isinstance(st, BranchState) and isinstance(st.guard, A.Bool):
                nexts = [st.then if st.guard.value else st.orelse]
            for n in nexts:
                if n not in seen:
                    seen.add(n)
                    todo.append(n)
        for st in fsm.states.values():
            if st.name not in seen and st.kind != "end":
                p = self.c.program
                raise CheckError(
                    f"unreachable statement: state '{st.name}' can never run", file=p.file,
                    line=st.line, column=st.column, source_line=source_line(p.source, st.line),
                    hint="a loop before it never ends, or a condition is always false",
                )


def compile_program(checked: CheckedProgram) -> FSM:
    """Build the FSM of a checked program (CheckError for unreachable statements)."""
    return _Compiler(checked).build()
