"""The compiled program: an explicit finite state machine, plain data that round-trips.

One class per kind of state (its ``kind`` string names it in JSON):

- :class:`RunState` (``run``): warp one (sub-)template onto the scene with OSILA and move the
  hand along it.  ``template``/``tag`` name it, ``bindings`` map ICP names (or group prefixes)
  to expressions, ``pen_down`` says whether it touches the paper (the template's ``contact``
  unless overridden), ``constraints`` are its ``via``/``avoid`` constraints (those of the task
  calls around it first), each with the line and column it was written at; ``track`` (a
  :class:`Tracking`, or None) keeps ICPs live while it runs (``track c every 100 ms``).
- :class:`CallState` (``call``): enter a task; ``assign`` binds its parameters (slots
  ``PREFIX:NAME``).
- :class:`SetState` (``set``): ``let`` and loop counters; ``assign`` maps slots to expressions.
- :class:`WaitState` (``wait``): block on ``world.wait(event, *args)``; the value goes to slot
  ``into``.
- :class:`BranchState` (``branch``): evaluate ``guard``; go to ``then`` if it holds, else to
  ``orelse``.
- :class:`EndState` (``end``): the program is done.

Every state but ``end`` has ``next`` (or ``then``/``orelse``) and the program ``line`` and
``column`` it came from.  State names show the hierarchy: ``main/mark#2/draw`` is the ``draw``
sub-template run by the second call of ``mark`` in ``main``.  :meth:`FSM.to_json`,
:meth:`FSM.to_dot` and :meth:`FSM.to_text` render it; expressions appear as hila source,
variables as ``{slot}``.  :meth:`FSM.from_dict` reads :meth:`FSM.to_dict` back:
``FSM.from_dict(fsm.to_dict()) == fsm`` for every program.

A new kind of state is one subclass here: its fields, ``describe``, and ``_fields_to_dict`` /
``_fields_from_dict`` (the base class does name, line, column and ``next``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import ClassVar

from .ast import Constraint, expr_text, Pos

END_STATE = "end"

#: kind -> state class, filled by :meth:`State.__init_subclass__`
STATE_KINDS: dict[str, type["State"]] = {}


def _exprs_to_dict(pairs) -> dict:
    return {k: expr_text(v) for k, v in pairs}


def _exprs_from_dict(d) -> tuple:
    # lazy: loads lark, which importing this module does not
    from .transformer import parse_expr

    return tuple((k, parse_expr(v)) for k, v in (d or {}).items())


@dataclass(eq=True)
class State:
    """What every state has: its name, where it came from, and the state after it."""

    name: str
    line: int = 0
    column: int = 0
    next: str | None = None

    kind: ClassVar[str] = ""
    #: node shape in :meth:`FSM.to_dot`
    shape: ClassVar[str] = "box"

    @property
    def highlight(self) -> bool:
        """Filled in :meth:`FSM.to_dot` (a run that draws)."""
        return False

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if cls.kind:
            STATE_KINDS[cls.kind] = cls

    def successors(self) -> list[str]:
        return [self.next] if self.next is not None else []

    def describe(self) -> str:
        """One line: what the state does."""
        raise NotImplementedError

    def flow(self) -> str:
        """Where control goes, for :meth:`FSM.to_text`."""
        return f"-> {self.next}" if self.next else ""

    def edges(self) -> list[tuple[str, str]]:
        """(target, label) pairs for :meth:`FSM.to_dot`."""
        return [(self.next, "")] if self.next else []

    def _fields_to_dict(self) -> dict:
        return {}

    @classmethod
    def _fields_from_dict(cls, d: dict) -> dict:
        return {}

    def to_dict(self) -> dict:
        d: dict = {"name": self.name, "kind": self.kind, "line": self.line, "column": self.column}
        d.update(self._fields_to_dict())
        if self.next is not None:
            d["next"] = self.next
        return d

    @staticmethod
    def from_dict(d: dict) -> "State":
        """The state :meth:`to_dict` wrote (expressions parsed back from their text)."""
        cls = STATE_KINDS[d["kind"]]
        return cls(name=d["name"], line=int(d.get("line", 0)), column=int(d.get("column", 0)),
                   next=d.get("next"), **cls._fields_from_dict(d))


def _constraint_text(c) -> str:
    """A resolved constraint in FSM dumps: variables as ``{slot}`` (like the bindings)."""
    return f"{c.kind} {expr_text(c.value)}" + ("" if c.radius is None else f" radius {expr_text(c.radius)}")


def _constraint_to_dict(c) -> dict:
    return {"kind": c.kind, "value": expr_text(c.value),
            **({} if c.radius is None else {"radius": expr_text(c.radius)}),
            "line": c.pos.line, "column": c.pos.column}


def _constraint_from_dict(d: dict):
    # lazy: loads lark, which importing this module does not
    from .transformer import parse_expr

    radius = d.get("radius")
    return Constraint(d["kind"], parse_expr(d["value"]), None if radius is None else parse_expr(radius),
                      Pos(int(d.get("line", 0)), int(d.get("column", 0))))


#: ``track`` without ``every``: perceive the tracked points every 100 ms (a re-warp at 100 ms closes
#: the issue-34 circle within 2 mm: ``bench/replan.py``; each tick costs the PyBullet robot one eye image)
TRACK_EVERY = 0.1
#: ``track`` without ``threshold``: re-warp when a tracked point moved more than 1 mm (the robot's
#: sheet estimate from one eye image jitters by less: docs/language.md, "Moving scenes")
TRACK_THRESHOLD = 0.001
#: ``track`` without ``blend``: the new plan is blended in over 5 mm of the path
TRACK_BLEND = 0.005


@dataclass(frozen=True)
class Tracking:
    """A run's ``track`` clause, with its defaults filled in.

    Attributes
    ----------
    names : tuple of Expr
        The tracked groups or points, variables resolved to slots.
    every : float
        Seconds between two looks.
    threshold : float
        A tracked point moved more than this (metres) from where the plan put it: warp again.
    blend : float
        Metres of path over which the new plan takes over (minimum jerk).
    lift : float or None
        A move larger than this (metres) lifts a pen that is down, travels and puts it down
        where its ink stopped; None: never.
    """

    names: tuple = ()
    every: float = TRACK_EVERY
    threshold: float = TRACK_THRESHOLD
    blend: float = TRACK_BLEND
    lift: float | None = None

    def text(self) -> str:
        words = [f"track {', '.join(expr_text(n) for n in self.names)} every {self.every * 1000:g} ms",
                 f"threshold {self.threshold * 1000:g} mm", f"blend {self.blend * 1000:g} mm"]
        if self.lift is not None:
            words.append(f"lift above {self.lift * 1000:g} mm")
        return " ".join(words)

    def to_dict(self) -> dict:
        return {"names": [expr_text(n) for n in self.names], "every": self.every, "threshold": self.threshold,
                "blend": self.blend, "lift": self.lift}

    @classmethod
    def from_dict(cls, d: dict) -> "Tracking":
        # lazy: loads lark, which importing this module does not
        from .transformer import parse_expr

        return cls(tuple(parse_expr(n) for n in d["names"]), float(d["every"]), float(d["threshold"]),
                   float(d["blend"]), None if d.get("lift") is None else float(d["lift"]))


@dataclass(eq=True)
class RunState(State):
    template: str | None = None
    tag: str | None = None
    bindings: tuple = ()  # ((icp, Expr), ...)
    pen_down: bool | None = None
    constraints: tuple = ()  # (ast.Constraint with slots resolved, ...)
    track: Tracking | None = None

    kind: ClassVar[str] = "run"
    shape: ClassVar[str] = "box"

    @property
    def highlight(self) -> bool:
        return bool(self.pen_down)

    @property
    def ref(self) -> str:
        return self.template if self.tag is None else f"{self.template}.{self.tag}"

    def describe(self) -> str:
        binds = ", ".join(f"{expr_text(v)}.*" if k == "*" else f"{k} = {expr_text(v)}" for k, v in self.bindings)
        limits = "".join(" " + _constraint_text(c) for c in self.constraints)
        track = "" if self.track is None else " " + self.track.text()
        return f"run {self.ref}({binds}) pen {'down' if self.pen_down else 'up'}{limits}{track}"

    def _fields_to_dict(self) -> dict:
        d = {"template": self.template, "tag": self.tag, "pen_down": self.pen_down,
             "bindings": _exprs_to_dict(self.bindings)}
        if self.constraints:  # only when there are some: older dumps stay as they were
            d["constraints"] = [_constraint_to_dict(c) for c in self.constraints]
        if self.track is not None:  # likewise
            d["track"] = self.track.to_dict()
        return d

    @classmethod
    def _fields_from_dict(cls, d: dict) -> dict:
        return {"template": d["template"], "tag": d.get("tag"), "pen_down": d.get("pen_down"),
                "bindings": _exprs_from_dict(d.get("bindings")),
                "constraints": tuple(_constraint_from_dict(c) for c in d.get("constraints") or ()),
                "track": None if d.get("track") is None else Tracking.from_dict(d["track"])}


@dataclass(eq=True)
class SetState(State):
    assign: tuple = ()  # ((slot, Expr), ...)

    kind: ClassVar[str] = "set"
    shape: ClassVar[str] = "note"

    def describe(self) -> str:
        return "set " + self._assignments()

    def _assignments(self) -> str:
        return ", ".join(f"{{{k}}} = {expr_text(v)}" for k, v in self.assign)

    def _fields_to_dict(self) -> dict:
        return {"assign": _exprs_to_dict(self.assign)}

    @classmethod
    def _fields_from_dict(cls, d: dict) -> dict:
        return {"assign": _exprs_from_dict(d.get("assign"))}


@dataclass(eq=True)
class CallState(SetState):
    task: str | None = None

    kind: ClassVar[str] = "call"
    shape: ClassVar[str] = "folder"

    def describe(self) -> str:
        return f"call {self.task}: " + self._assignments()

    def _fields_to_dict(self) -> dict:
        return {"task": self.task, **super()._fields_to_dict()}

    @classmethod
    def _fields_from_dict(cls, d: dict) -> dict:
        return {"task": d["task"], **super()._fields_from_dict(d)}


@dataclass(eq=True)
class WaitState(State):
    event: str | None = None
    args: tuple = ()
    into: str | None = None

    kind: ClassVar[str] = "wait"
    shape: ClassVar[str] = "parallelogram"

    def describe(self) -> str:
        args = f"({', '.join(expr_text(a) for a in self.args)})" if self.args else ""
        return f"wait {self.event}{args}" + (f" -> {{{self.into}}}" if self.into else "")

    def _fields_to_dict(self) -> dict:
        return {"event": self.event, "args": [expr_text(a) for a in self.args], "into": self.into}

    @classmethod
    def _fields_from_dict(cls, d: dict) -> dict:
        # lazy: loads lark, which importing this module does not
        from .transformer import parse_expr

        return {"event": d["event"], "args": tuple(parse_expr(a) for a in d.get("args") or ()),
                "into": d.get("into")}


@dataclass(eq=True)
class BranchState(State):
    guard: object = None
    then: str | None = None
    orelse: str | None = None

    kind: ClassVar[str] = "branch"
    shape: ClassVar[str] = "diamond"

    def successors(self) -> list[str]:
        return [s for s in (self.next, self.then, self.orelse) if s is not None]

    def describe(self) -> str:
        return f"if {expr_text(self.guard)}"

    def flow(self) -> str:
        return f"-> {self.then} | else -> {self.orelse}"

    def edges(self) -> list[tuple[str, str]]:
        return [(self.then, "yes"), (self.orelse, "no")]

    def _fields_to_dict(self) -> dict:
        return {"guard": expr_text(self.guard), "then": self.then, "orelse": self.orelse}

    @classmethod
    def _fields_from_dict(cls, d: dict) -> dict:
        # lazy: loads lark, which importing this module does not
        from .transformer import parse_expr

        return {"guard": parse_expr(d["guard"]), "then": d.get("then"), "orelse": d.get("orelse")}


@dataclass(eq=True)
class EndState(State):
    kind: ClassVar[str] = "end"
    shape: ClassVar[str] = "doublecircle"

    def describe(self) -> str:
        return "end"


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

    @classmethod
    def from_dict(cls, d: dict) -> "FSM":
        """The machine :meth:`to_dict` wrote (``hila_fsm: 1``)."""
        # lazy: loads lark, which importing this module does not
        from .transformer import parse_expr

        if d.get("hila_fsm") != 1:
            raise ValueError(f"expected an FSM dump with hila_fsm: 1, got {d.get('hila_fsm')!r}")
        states = [State.from_dict(s) for s in d["states"]]
        return cls(d["program"], d["world"], d["start"], {s.name: s for s in states}, dict(d.get("templates") or {}),
                   {k: parse_expr(v) for k, v in (d.get("points") or {}).items()},
                   None if d.get("hand") is None else parse_expr(d["hand"]))

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2) + "\n"

    def to_text(self) -> str:
        width = max(len(n) for n in self.states)
        lines = [f"fsm {self.file} (world {self.world}), start {self.start}"]
        for s in self.states.values():
            line = f"line {s.line:>3}" if s.line else "        "
            lines.append(f"  {s.name:<{width}}  {line}  {s.describe()}  {s.flow()}".rstrip())
        return "\n".join(lines) + "\n"

    def to_dot(self) -> str:
        def q(text: str) -> str:
            return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'

        out = ["digraph hila {", "  rankdir=TB;", '  node [fontname="Helvetica", fontsize=10];',
               f"  __start [shape=point]; __start -> {q(self.start)};"]
        for s in self.states.values():
            label = s.name if s.kind == "end" else f"{s.name}\n{s.describe()}"
            style = ', style=filled, fillcolor="#ffe9a8"' if s.highlight else ""
            out.append(f"  {q(s.name)} [shape={s.shape}, label={q(label)}{style}];")
        for s in self.states.values():
            for target, label in s.edges():
                out.append(f"  {q(s.name)} -> {q(target)}" + (f" [label=\"{label}\"];" if label else ";"))
        out.append("}")
        return "\n".join(out) + "\n"
