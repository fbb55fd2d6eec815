"""The scene as a program sees it while it runs: its variables, the names of points (``hand``, the
program's ``point`` s, the world's ``points()``), and the values of expressions over them.

:class:`Scene` holds the variables (``env``: slot -> value) and answers names; :class:`Evaluator`
computes an expression against one scene.  Neither knows the step loop or the states: an
executor (:mod:`hila_lang.engine.executors`) asks its scene for values.  A name or a value the
program cannot use is a :class:`~hila_lang.core.errors.HilaRuntimeError` (the step loop adds the
state and the line).
"""

from __future__ import annotations

import difflib
from typing import Any

import numpy as np

from ..core.errors import HilaRuntimeError
from ..language import ast as A
from .trace import fmt_value

#: an expression as the user wrote it (variables by name, not by slot), for messages
src = A.source_text


class Scene:
    """Variables and scene names of one run: ``world`` (its ``points()`` and ``query``),
    ``backend`` (where the hand is), ``points`` (the program's named points: name -> expression)."""

    def __init__(self, world, backend, points: dict) -> None:
        self.world, self.backend, self.points = world, backend, points
        self.env: dict[str, Any] = {}
        self.evaluator = Evaluator(self)

    def eval(self, e) -> Any:
        """The value of expression ``e`` now."""
        return self.evaluator.visit(e)

    def hand(self) -> np.ndarray:
        return np.asarray(self.backend.hand_position(), dtype=float)

    def scene_points(self) -> dict[str, np.ndarray]:
        """Every named point: the world's, then the program's."""
        pts = dict(self.world.points())
        for name, expr in self.points.items():
            pts[name] = self.point(expr)
        return pts

    def lookup(self, name: str, points: dict | None = None):
        """A scene point by full name -> (3,); a group prefix -> its name (str)."""
        if name == "hand":
            return self.hand()
        if name.startswith("hand.") and name[5:] in ("x", "y", "z"):
            return float(self.hand()["xyz".index(name[5:])])
        if name in self.points:
            return self.point(self.points[name])
        points = self.world.points() if points is None else points
        if name in points:  # None: a point the world knows of but does not see now (binds an ICP to none)
            return None if points[name] is None else np.asarray(points[name], dtype=float)
        if any(k.startswith(name + ".") for k in points) or any(k.startswith(name + ".") for k in self.points):
            return name
        head, _, attr = name.rpartition(".")
        if attr in ("x", "y", "z") and head:
            base = self.lookup(head, points)
            if isinstance(base, np.ndarray):
                return float(base["xyz".index(attr)])
        close = difflib.get_close_matches(name, list(points) + list(self.points), n=1)
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
                               f"from '{src(expr)}'")

    def point(self, expr, allow_none: bool = False):
        """The point ``expr`` names or computes: (2,) or (3,); None only when ``allow_none``."""
        value = self.eval(expr)
        if value is None and allow_none:
            return None
        if isinstance(value, str):
            value = self.lookup(value)
        if isinstance(value, np.ndarray) and value.shape in ((3,), (2,)):
            return value
        raise HilaRuntimeError(f"expected a point, got {fmt_value(value)} from '{src(expr)}'")

    def points_of(self, expr) -> list[tuple[str | None, np.ndarray]]:
        """A point (``[(None, p)]``) or every point of a group (``[(name, p), ...]``, scene order)."""
        value = self.eval(expr)
        if isinstance(value, str):
            value = self.lookup(value)
        if isinstance(value, np.ndarray) and value.shape in ((2,), (3,)):
            return [(None, value)]
        if isinstance(value, str):  # a group prefix: its points, the world's then the program's
            members = [(k, np.asarray(p, dtype=float)) for k, p in self.scene_points().items()
                       if k.startswith(value + ".")]
            if members:
                return members
        raise HilaRuntimeError(f"expected a point or a point group, got {fmt_value(value)} from '{src(expr)}'")


def plain(value):
    """World answers as hila values: numpy scalars -> Python, sequences of 2-3 numbers -> points."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)) and len(value) in (2, 3) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return np.asarray(value, dtype=float)
    return value


class Evaluator(A.Visitor):
    """Expression evaluation against one :class:`Scene`: its variables, names and world."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene

    def generic_visit(self, e):  # pragma: no cover - every expression has its method
        raise HilaRuntimeError(f"cannot evaluate {e!r}")

    def visit_Number(self, e):
        return e.value

    visit_String = visit_Bool = visit_Number

    def visit_NoneLit(self, e):
        return None

    def visit_Var(self, e):
        env = self.scene.env
        if e.slot not in env:
            name = e.slot.rsplit(":", 1)[1]
            raise HilaRuntimeError(f"'{name}' has no value yet (its 'let' has not run)")
        value = env[e.slot]
        for attr in e.attrs:
            value = self._attr(value, attr)
        return value

    def visit_Name(self, e):
        return self.scene.lookup(e.text)

    def visit_Vector(self, e):
        items = [self.visit(i) for i in e.items]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in items):
            raise HilaRuntimeError(f"a point's coordinates must be numbers in '{src(e)}'")
        return np.array(items, dtype=float)

    def visit_Unary(self, e):
        v = self.visit(e.operand)
        if e.op == "not":
            return not self._bool(v, e.operand)
        return -self._number_or_point(v, e)

    def visit_Ask(self, e):
        args = [self.visit(a) for a in e.args]
        return plain(self.scene.world.query(e.name, *args))

    def _attr(self, value, attr: str):
        if isinstance(value, str):
            return self.scene.lookup(f"{value}.{attr}")
        if isinstance(value, np.ndarray) and attr in ("x", "y", "z") and value.shape[0] > "xyz".index(attr):
            return float(value["xyz".index(attr)])
        raise HilaRuntimeError(f"{fmt_value(value)} has no part '.{attr}'")

    def _bool(self, v, expr) -> bool:
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        raise HilaRuntimeError(f"expected true or false, got {fmt_value(v)} from '{src(expr)}'")

    def _number_or_point(self, v, expr):
        if isinstance(v, str):
            v = self.scene.lookup(v)
        if isinstance(v, (int, float, np.ndarray)) and not isinstance(v, bool):
            return v
        raise HilaRuntimeError(f"expected a number or a point, got {fmt_value(v)} in '{src(expr)}'")

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
                raise HilaRuntimeError(f"cannot order points in '{src(e)}'")
            return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b}[e.op]
        if e.op == "/" and not isinstance(b, np.ndarray) and b == 0:
            raise HilaRuntimeError(f"division by zero in '{src(e)}'")
        if isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape != b.shape:
            raise HilaRuntimeError(f"points of different sizes in '{src(e)}'")
        return {"+": lambda: a + b, "-": lambda: a - b, "*": lambda: a * b, "/": lambda: a / b}[e.op]()


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
