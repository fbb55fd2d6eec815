"""The compiled program: an explicit finite state machine, plain data.

Kinds of state (``State.kind``):

- ``run``: warp one (sub-)template onto the scene with OSILA and move the hand along it.
  ``template``/``tag`` name it, ``bindings`` map ICP names (or group prefixes) to expressions,
  ``pen_down`` says whether it touches the paper (the template's ``contact`` unless overridden).
- ``call``: enter a task; ``assign`` binds its parameters (slots ``PREFIX:NAME``).
- ``set``: ``let`` and loop counters; ``assign`` maps slots to expressions.
- ``wait``: block on ``world.wait(event, *args)``; the value goes to slot ``into``.
- ``branch``: evaluate ``guard``; go to ``then`` if it holds, else to ``orelse``.
- ``end``: the program is done.

Every state but ``end`` has ``next`` (or ``then``/``orelse``) and the program ``line`` it came
from.  State names show the hierarchy: ``main/mark#2/draw`` is the ``draw`` sub-template run by
the second call of ``mark`` in ``main``.  :meth:`FSM.to_json`, :meth:`FSM.to_dot` and
:meth:`FSM.to_text` render it; expressions appear as hila source, variables as ``{slot}``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from .ast import expr_text

END_STATE = "end"


@dataclass
class State:
    name: str
    kind: str
    line: int = 0
    column: int = 0
    next: str | None = None
    template: str | None = None
    tag: str | None = None
    bindings: tuple = ()  # ((icp, Expr), ...)
    pen_down: bool | None = None
    assign: tuple = ()  # ((slot, Expr), ...)
    event: str | None = None
    args: tuple = ()
    into: str | None = None
    guard: object = None
    then: str | None = None
    orelse: str | None = None
    task: str | None = None

    def successors(self) -> list[str]:
        return [s for s in (self.next, self.then, self.orelse) if s is not None]

    @property
    def ref(self) -> str:
        return self.template if self.tag is None else f"{self.template}.{self.tag}"

    def describe(self) -> str:
        """One line: what the state does."""
        if self.kind == "run":
            binds = ", ".join(f"{expr_text(v)}.*" if k == "*" else f"{k} = {expr_text(v)}" for k, v in self.bindings)
            return f"run {self.ref}({binds}) pen {'down' if self.pen_down else 'up'}"
        if self.kind in ("set", "call"):
            head = f"call {self.task}: " if self.kind == "call" else "set "
            return head + ", ".join(f"{{{k}}} = {expr_text(v)}" for k, v in self.assign)
        if self.kind == "wait":
            args = f"({', '.join(expr_text(a) for a in self.args)})" if self.args else ""
            return f"wait {self.event}{args}" + (f" -> {{{self.into}}}" if self.into else "")
        if self.kind == "branch":
            return f"if {expr_text(self.guard)}"
        return "end"

    def to_dict(self) -> dict:
        d: dict = {"name": self.name, "kind": self.kind, "line": self.line}
        if self.kind == "run":
            d.update(template=self.template, tag=self.tag, pen_down=self.pen_down,
                     bindings={k: expr_text(v) for k, v in self.bindings})
        elif self.kind in ("set", "call"):
            if self.task:
                d["task"] = self.task
            d["assign"] = {k: expr_text(v) for k, v in self.assign}
        elif self.kind == "wait":
            d.update(event=self.event, args=[expr_text(a) for a in self.args], into=self.into)
        elif self.kind == "branch":
            d.update(guard=expr_text(self.guard), then=self.then, orelse=self.orelse)
        if self.next is not None:
            d["next"] = self.next
        return d


@dataclass
class FSM:
    """States by name (in program order), the start state, and what the program declared."""

    file: str
    world: str
    start: str
    states: dict[str, State]
    templates: dict[str, str] = field(default_factory=dict)  # alias -> source as imported
    points: dict = field(default_factory=dict)  # name -> Expr
    hand: object = None  # Expr or None

    def __getitem__(self, name: str) -> State:
        return self.states[name]

    def to_dict(self) -> dict:
        return {
            "hila_fsm": 1,
            "program": self.file,
            "world": self.world,
            "templates": dict(self.templates),
            "points": {k: expr_text(v) for k, v in self.points.items()},
            "hand": None if self.hand is None else expr_text(self.hand),
            "start": self.start,
            "states": [s.to_dict() for s in self.states.values()],
        }

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2) + "\n"

    def to_text(self) -> str:
        width = max(len(n) for n in self.states)
        lines = [f"fsm {self.file} (world {self.world}), start {self.start}"]
        for s in self.states.values():
            if s.kind == "branch":
                flow = f"-> {s.then} | else -> {s.orelse}"
            else:
                flow = f"-> {s.next}" if s.next else ""
            line = f"line {s.line:>3}" if s.line else "        "
            lines.append(f"  {s.name:<{width}}  {line}  {s.describe()}  {flow}".rstrip())
        return "\n".join(lines) + "\n"

    def to_dot(self) -> str:
        def q(text: str) -> str:
            return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'

        shapes = {"run": "box", "branch": "diamond", "wait": "parallelogram", "end": "doublecircle",
                  "call": "folder", "set": "note"}
        out = ["digraph hila {", "  rankdir=TB;", '  node [fontname="Helvetica", fontsize=10];',
               f"  __start [shape=point]; __start -> {q(self.start)};"]
        for s in self.states.values():
            label = s.name if s.kind == "end" else f"{s.name}\n{s.describe()}"
            style = ', style=filled, fillcolor="#ffe9a8"' if s.kind == "run" and s.pen_down else ""
            out.append(f"  {q(s.name)} [shape={shapes[s.kind]}, label={q(label)}{style}];")
        for s in self.states.values():
            if s.kind == "branch":
                out.append(f"  {q(s.name)} -> {q(s.then)} [label=\"yes\"];")
                out.append(f"  {q(s.name)} -> {q(s.orelse)} [label=\"no\"];")
            elif s.next:
                out.append(f"  {q(s.name)} -> {q(s.next)};")
        out.append("}")
        return "\n".join(out) + "\n"
