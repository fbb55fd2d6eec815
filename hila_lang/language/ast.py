"""The hila abstract syntax tree: frozen dataclasses named after grammar rules.

Only :mod:`hila_lang.language.transformer` builds these nodes.  Every node carries ``pos``
(line, column, end line, end column of its source text, 1-based); positions do not take part
in equality, so two programs that differ only in layout compare equal.

:func:`dump` renders a tree as indented text (the AST golden files); :func:`expr_text` renders
an expression back as hila source (FSM dumps, traces, error messages).  :class:`Visitor` is the one
way passes walk the tree (:func:`children` lists a node's parts generically).
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field, fields, is_dataclass, replace
from typing import Union


@dataclass(frozen=True)
class Pos:
    """Source span, 1-based, end exclusive as lark reports it."""

    line: int = 0
    column: int = 0
    end_line: int = 0
    end_column: int = 0

    def __str__(self) -> str:
        return f"{self.line}:{self.column}"


NOPOS = Pos()


def _pos():
    return field(default=NOPOS, compare=False, repr=False)


# --------------------------------------------------------------------------- expressions


@dataclass(frozen=True)
class Number:
    value: float
    pos: Pos = _pos()


@dataclass(frozen=True)
class String:
    value: str
    pos: Pos = _pos()


@dataclass(frozen=True)
class Bool:
    value: bool
    pos: Pos = _pos()


@dataclass(frozen=True)
class NoneLit:
    """``none``: as an ICP binding, leaves that ICP out of the warp."""

    pos: Pos = _pos()


@dataclass(frozen=True)
class Name:
    """A dotted name: a variable (``c``, ``c.tl``), ``hand``, or a scene point (``board.cell5.tl``)."""

    parts: tuple[str, ...]
    pos: Pos = _pos()

    @property
    def text(self) -> str:
        return ".".join(self.parts)


@dataclass(frozen=True)
class Var:
    """A variable resolved by the compiler to its slot (``main/mark:c``), plus ``.attr`` parts."""

    slot: str
    attrs: tuple[str, ...] = ()
    pos: Pos = _pos()


@dataclass(frozen=True)
class Vector:
    """A literal point ``(x, y)`` or ``(x, y, z)``, metres."""

    items: tuple["Expr", ...]
    pos: Pos = _pos()


@dataclass(frozen=True)
class Unary:
    op: str  # "-" or "not"
    operand: "Expr"
    pos: Pos = _pos()


@dataclass(frozen=True)
class Binary:
    op: str  # and or == != < <= > >= + - * /
    left: "Expr"
    right: "Expr"
    pos: Pos = _pos()


@dataclass(frozen=True)
class Ask:
    """``ask NAME(args)``: a value or predicate computed by the world (``world.query``)."""

    name: str
    args: tuple["Expr", ...] = ()
    pos: Pos = _pos()


@dataclass(frozen=True)
class Wait:
    """``wait EVENT(args)``: block until the world reports the event (``world.wait``)."""

    event: str
    args: tuple["Expr", ...] = ()
    pos: Pos = _pos()


Expr = Union[Number, String, Bool, NoneLit, Name, Var, Vector, Unary, Binary, Ask]

# --------------------------------------------------------------------------- statements


SPREAD = "*"


@dataclass(frozen=True)
class Binding:
    """``icp = value`` inside ``run``; ``icp`` may name a group (``cell`` binds ``cell.tl``, ...).

    ``c.*`` is a *spread* (``icp == SPREAD``): every scene ICP ``K`` not bound by name is bound
    to the point ``c.K``.
    """

    icp: str
    value: Expr
    pos: Pos = _pos()


@dataclass(frozen=True)
class Constraint:
    """``via POINT`` (a forced waypoint) or ``avoid POINT radius R`` (an obstacle, a sphere), after a
    ``run`` or a task call (where it applies to every run inside the task).

    ``value`` is a point or a point group (each of its points is one waypoint or one sphere);
    ``radius`` (metres) only for ``avoid``.  OSILA's plan adjustment meets them.
    """

    kind: str  # "via" or "avoid"
    value: "Expr"
    radius: "Expr | None" = None
    pos: Pos = _pos()

    def text(self) -> str:
        """As the user wrote it (variables by name): ``avoid cup radius 0.04``."""
        radius = "" if self.radius is None else f" radius {source_text(self.radius)}"
        return f"{self.kind} {source_text(self.value)}{radius}"


@dataclass(frozen=True)
class TrackOption:
    """One option of a ``track`` clause: ``every N ms``, ``threshold N mm``, ``blend N mm`` or
    ``lift above N mm`` (``kind`` is its first word, ``value`` the number as written, in the unit
    written after it)."""

    kind: str  # "every", "threshold", "blend" or "lift"
    value: float
    pos: Pos = _pos()

    #: the unit each option is written in
    UNITS = {"every": "ms", "threshold": "mm", "blend": "mm", "lift": "mm"}

    def text(self) -> str:
        return f"{self.kind}{' above' if self.kind == 'lift' else ''} {number_text(self.value)} {self.UNITS[self.kind]}"


@dataclass(frozen=True)
class Track:
    """``track c[, d] [every N ms] [threshold N mm] [blend N mm] [lift above N mm]`` after a
    ``run``: the ICPs bound through ``c`` (a point group or a point) are perceived again while the
    step runs, and the rest of the step is warped again onto them when they move
    (:mod:`hila_lang.engine.tracking`)."""

    names: tuple[Name, ...]
    options: tuple[TrackOption, ...] = ()
    pos: Pos = _pos()

    def option(self, kind: str) -> "TrackOption | None":
        """The option of ``kind`` as written (the first, if written twice), or None."""
        return next((o for o in self.options if o.kind == kind), None)

    def text(self) -> str:
        """As the user wrote it (variables by name)."""
        return " ".join(["track " + ", ".join(source_text(n) for n in self.names)]
                        + [o.text() for o in self.options])


#: grammar rule -> the statement class it writes (:func:`statement`)
RULES: dict[str, type] = {}


def statement(rule: str):
    """Class decorator: a statement, written by the grammar's ``rule`` (``grammar/hila.lark``).

    :mod:`hila_lang.language.transformer` builds it from the rule's children in order (keywords
    dropped, a token as its text, an absent ``[optional]`` as None) and ``pos``, unless it has a
    method of its own for the rule; the checker checks the names in its expressions and the
    statements in its blocks unless it has a ``visit_`` method for it.  So a new statement whose
    fields are its rule's children is the rule, this class, and the compiler's ``visit_`` method.
    """
    def register(cls):
        RULES[rule] = cls
        return cls

    return register


def _constraints():
    """The ``constraints`` field of a run or a call: omitted from :func:`dump` when empty."""
    return field(default=(), metadata={"omit_empty": True})


@statement("run_stmt")
@dataclass(frozen=True)
class RunStmt:
    """``run TEMPLATE[.TAG](bindings) [pen up|down] [via P] [avoid P radius R] ... [track c ...]``."""

    template: str
    tag: str | None
    bindings: tuple[Binding, ...]
    pen: str | None = None
    pos: Pos = _pos()
    ref_pos: Pos = _pos()  # where ``TEMPLATE.TAG`` is written
    constraints: tuple[Constraint, ...] = _constraints()
    track: Track | None = field(default=None, metadata={"omit_empty": True})

    @property
    def ref(self) -> str:
        return self.template if self.tag is None else f"{self.template}.{self.tag}"


@statement("call_stmt")
@dataclass(frozen=True)
class CallStmt:
    task: str
    args: tuple[Expr, ...]
    pos: Pos = _pos()
    constraints: tuple[Constraint, ...] = _constraints()


@statement("let_stmt")
@dataclass(frozen=True)
class LetStmt:
    name: str
    value: Union[Expr, Wait]
    pos: Pos = _pos()


@statement("wait_stmt")
@dataclass(frozen=True)
class WaitStmt:
    wait: Wait
    pos: Pos = _pos()


@statement("if_stmt")
@dataclass(frozen=True)
class IfStmt:
    """``if c {..} else if c {..} else {..}``: ``branches`` pairs (condition, body)."""

    branches: tuple[tuple[Expr, tuple["Stmt", ...]], ...]
    orelse: tuple["Stmt", ...] | None = None
    pos: Pos = _pos()


@statement("while_stmt")
@dataclass(frozen=True)
class WhileStmt:
    cond: Expr
    body: tuple["Stmt", ...]
    pos: Pos = _pos()


@statement("until_stmt")
@dataclass(frozen=True)
class UntilStmt:
    """``until c {..}``: test ``c`` before each round, stop when it holds."""

    cond: Expr
    body: tuple["Stmt", ...]
    pos: Pos = _pos()


@statement("repeat_stmt")
@dataclass(frozen=True)
class RepeatStmt:
    count: Expr
    body: tuple["Stmt", ...]
    pos: Pos = _pos()


Stmt = Union[RunStmt, CallStmt, LetStmt, WaitStmt, IfStmt, WhileStmt, UntilStmt, RepeatStmt]  # for type hints
#: the statement classes (for ``isinstance``): every class registered with :func:`statement`
STATEMENTS = tuple(RULES.values())

# --------------------------------------------------------------------------- top level


@dataclass(frozen=True)
class WorldDecl:
    name: str
    pos: Pos = _pos()


@dataclass(frozen=True)
class ImportDecl:
    """``import NAME`` (``primitives/NAME.yaml``) or ``import "file.yaml" as NAME``."""

    source: str
    alias: str
    is_path: bool = False
    pos: Pos = _pos()


@dataclass(frozen=True)
class PointDecl:
    name: str
    value: Expr
    pos: Pos = _pos()


@dataclass(frozen=True)
class HandDecl:
    value: Expr
    pos: Pos = _pos()


@dataclass(frozen=True)
class TaskDef:
    name: str
    params: tuple[str, ...]
    body: tuple[Stmt, ...]
    pos: Pos = _pos()
    param_pos: tuple[Pos, ...] = _pos()


@dataclass(frozen=True)
class MainDef:
    body: tuple[Stmt, ...]
    pos: Pos = _pos()


@dataclass(frozen=True)
class Program:
    """A whole ``.hila`` file, items in source order."""

    items: tuple[Union[WorldDecl, ImportDecl, PointDecl, HandDecl, TaskDef, MainDef], ...]
    file: str = field(default="<program>", compare=False)
    source: str = field(default="", compare=False, repr=False)

    def of(self, kind: type) -> list:
        """Items of one kind, in source order."""
        return [i for i in self.items if isinstance(i, kind)]


# --------------------------------------------------------------------------- visiting


_FIELDS: dict[type, tuple[str, ...]] = {}


def _compared_fields(cls: type) -> tuple[str, ...]:
    """Names of the fields that take part in equality (the node's parts, not its position)."""
    names = _FIELDS.get(cls)
    if names is None:
        names = _FIELDS[cls] = tuple(f.name for f in fields(cls) if f.compare)
    return names


def _add_nodes(value, out: list) -> None:
    if type(value) is tuple:
        for v in value:
            _add_nodes(v, out)
    elif hasattr(type(value), "__dataclass_fields__") and type(value) is not Pos:
        out.append(value)


def children(node) -> list:
    """The AST nodes directly inside ``node``, in field order (bodies flattened, if-branches as
    condition then body).  Every pass walks the tree through this one function, so a new node
    class needs no walking code of its own."""
    out: list = []
    for name in _compared_fields(type(node)):
        value = getattr(node, name)
        if value is None or type(value) in _LEAVES:
            continue
        _add_nodes(value, out)
    return out


_LEAVES = {str, float, int, bool, Pos}


class Visitor:
    """Dispatch on the node's class: ``visit(node, *args)`` calls ``visit_<ClassName>(node, *args)``,
    or :meth:`generic_visit` (which visits every child) when there is no such method.

    The checker, the compiler, the interpreter's evaluator and :func:`expr_text` are visitors.
    """

    def visit(self, node, *args):
        method = getattr(self, "visit_" + type(node).__name__, None)
        return method(node, *args) if method is not None else self.generic_visit(node, *args)

    def generic_visit(self, node, *args):
        for child in children(node):
            self.visit(child, *args)


@functools.lru_cache(maxsize=None)
def _all_fields(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in fields(cls))


def shift_lines(node, lines: int):
    """A copy of ``node`` (a node, or a tuple of them) written ``lines`` lines further down: every
    position moved, nothing else changed (the language server reuses a top-level item that moved)."""
    if isinstance(node, tuple):
        return tuple(shift_lines(n, lines) for n in node)
    if isinstance(node, Pos):
        return Pos(node.line + lines, node.column, node.end_line + lines, node.end_column) if node.line else node
    if not hasattr(type(node), "__dataclass_fields__"):
        return node
    changes = {}
    for name in _all_fields(type(node)):
        value = getattr(node, name)
        moved = shift_lines(value, lines)
        if moved is not value:
            changes[name] = moved
    return replace(node, **changes) if changes else node


def walk(body):
    """Every statement in ``body`` (a tuple of statements) and in the blocks nested in them, in
    source order; expressions are not entered."""
    for s in body:
        yield s
        for c in children(s):
            if isinstance(c, STATEMENTS):
                yield from walk((c,))


def map_names(e, fn):
    """A copy of expression ``e`` with every :class:`Name` ``n`` replaced by ``fn(n)``."""
    if isinstance(e, Name):
        return fn(e)
    if isinstance(e, Vector):
        return Vector(tuple(map_names(i, fn) for i in e.items), e.pos)
    if isinstance(e, Unary):
        return Unary(e.op, map_names(e.operand, fn), e.pos)
    if isinstance(e, Binary):
        return Binary(e.op, map_names(e.left, fn), map_names(e.right, fn), e.pos)
    if isinstance(e, Ask):
        return Ask(e.name, tuple(map_names(a, fn) for a in e.args), e.pos)
    return e


# --------------------------------------------------------------------------- rendering

_BINARY_PREC = {"or": 1, "and": 2, "==": 4, "!=": 4, "<": 4, "<=": 4, ">": 4, ">=": 4, "+": 5, "-": 5, "*": 6, "/": 6}
_COMPARE = {"==", "!=", "<", "<=", ">", ">="}


def number_text(v: float) -> str:
    return str(int(v)) if float(v).is_integer() and abs(v) < 1e15 else repr(float(v))


class _Text(Visitor):
    """Expressions back to hila source (see :func:`expr_text`)."""

    def generic_visit(self, node, prec=0):
        raise TypeError(f"not an expression: {node!r}")

    def visit_Number(self, e, prec=0):
        return number_text(e.value)

    def visit_String(self, e, prec=0):
        return f'"{e.value}"'

    def visit_Bool(self, e, prec=0):
        return "true" if e.value else "false"

    def visit_NoneLit(self, e, prec=0):
        return "none"

    def visit_Name(self, e, prec=0):
        return e.text

    def visit_Var(self, e, prec=0):
        return "".join([f"{{{e.slot}}}", *(f".{a}" for a in e.attrs)])

    def visit_Vector(self, e, prec=0):
        return "(" + ", ".join(self.visit(i) for i in e.items) + ")"

    def visit_Unary(self, e, prec=0):
        mine = 3 if e.op == "not" else 7
        text = f"not {self.visit(e.operand, 3)}" if e.op == "not" else f"-{self.visit(e.operand, 7)}"
        return f"({text})" if mine < prec else text

    def visit_Binary(self, e, prec=0):
        mine = _BINARY_PREC[e.op]
        # comparisons do not chain: a comparison on the left of another is parenthesised
        left = self.visit(e.left, mine + 1 if e.op in _COMPARE else mine)
        text = f"{left} {e.op} {self.visit(e.right, mine + 1)}"
        return f"({text})" if mine < prec else text

    def _call(self, word, name, args):
        return f"{word} {name}" + (f"({', '.join(self.visit(a) for a in args)})" if args else "")

    def visit_Ask(self, e, prec=0):
        return self._call("ask", e.name, e.args)

    def visit_Wait(self, e, prec=0):
        return self._call("wait", e.event, e.args)


_TEXT = _Text()


def expr_text(e, prec: int = 0) -> str:
    """Render an expression as hila source (a :class:`Var` as its slot, ``{main/mark:c}``);
    :func:`hila_lang.language.transformer.parse_expr` reads it back."""
    return _TEXT.visit(e, prec)


def source_text(e) -> str:
    """An expression as the user wrote it: :func:`expr_text` with variables by name, not by slot."""
    return re.sub(r"\{[^{}]*:([^{}]*)\}", r"\1", expr_text(e))


def dump(node, indent: int = 0) -> str:
    """Indented text of an AST (one node per line, with its ``line:column``)."""
    pad = "  " * indent
    if isinstance(node, (tuple, list)):
        return "\n".join(dump(n, indent) for n in node) if node else f"{pad}()"
    if not is_dataclass(node):
        return f"{pad}{node!r}"
    pos = getattr(node, "pos", None)
    head = f"{pad}{type(node).__name__}" + (f" @{pos}" if isinstance(pos, Pos) and pos.line else "")
    scalars, children = [], []
    for f in fields(node):
        if not f.compare:  # positions, file name, source text
            continue
        value = getattr(node, f.name)
        if f.metadata.get("omit_empty") and not value:
            continue
        if is_dataclass(value) or (isinstance(value, tuple) and value and not all(isinstance(v, str) for v in value)):
            children.append((f.name, value))
        elif isinstance(value, float):
            scalars.append(f"{f.name}={number_text(value)}")
        else:
            scalars.append(f"{f.name}={value!r}")
    lines = [head + ("  " + " ".join(scalars) if scalars else "")]
    for name, value in children:
        lines.append(f"{pad}  .{name}:")
        if isinstance(value, tuple) and value and isinstance(value[0], tuple):  # if-branches
            for cond, body in value:
                lines.append(dump(cond, indent + 2))
                lines.append(f"{pad}    then:")
                lines.append(dump(body, indent + 3))
        else:
            lines.append(dump(value, indent + 2))
    return "\n".join(lines)
