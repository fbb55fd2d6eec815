"""What a program asks of its world, checked against what the world declares -- before it runs.

The checker (:mod:`.checker`) calls :class:`WorldCheck` wherever a program names something the
world must answer:

- ``ask NAME`` and ``wait NAME``: a question or event the world declares
  (:class:`~hila_lang.plugins.registry.Declared`), or a :class:`CheckError` with "did you mean";
- a world point written out (``board.cell5.tl``), when the world knows its points before it
  runs (a script's);
- a target bound to an ICP, when the back end moves an arm (``BackendInfo.reach``: PyBullet, and
  the dry back end, which checks paths as PyBullet does): a point written out or a program
  point outside the arm's reach bound is refused at the statement that binds it (a run's
  binding, or the task call whose argument becomes the target), with its distances;
- the points bound to a template's ICPs: a 3-D template takes 3-D points; a 2-D template runs on
  the world's drawing surface (the scene points bound to it are projected onto the surface, see
  :func:`hila_lang.hierarchy.step.hila_step`), so a world without one refuses it, with the reason;
- what a pen-down (sub-)template draws, when the world declares a ``mark_check``
  (:meth:`~hila_lang.plugins.registry.WorldInfo.check_mark`): tic-tac-toe refuses a mark the
  robot could not tell from the opponent's cross, at the run statement that draws it.
- a ``track`` clause: the world must show the robot its points again while a step runs
  (``WorldInfo.tracking``) and the back end must follow a path that changes as it moves
  (``BackendInfo.streaming``); either missing is refused, with the reason.

The ``--set`` pairs are split and parsed here too (:func:`hila_lang.plugins.options.split_settings`),
so ``hila check`` and ``hila exec`` refuse a bad value alike, before anything is built.  When the
settings are not given (``settings=None``: the Python API, tools) a world whose names follow
from its settings is not checked by name: only the running world knows.
"""

from __future__ import annotations

from . import ast as A
from ..core.errors import did_you_mean
from ..plugins import registry


class WorldCheck:
    """The world of one program, as declared; ``error(message, pos, hint)`` makes a CheckError."""

    def __init__(self, world: str, error, settings: dict[str, str] | None = None,
                 backend: str | None = None) -> None:
        self.world = world
        self.error = error
        self.info = registry.world(world)
        self.run_settings = None  # (OSILA options, world settings, back-end settings), parsed
        parsed = None
        backend_info = registry.backend(backend or self.info.default_backend)
        #: ((x, y, z), radius): the ball the back end's hand stays in, or None
        self.reach_ball = backend_info.reach
        self.backend_name = backend_info.name
        self.backend_streams = backend_info.streaming
        self.robot_name = "the iCub"
        if settings is not None:
            # lazy: only this branch needs it
            from ..plugins.options import split_settings

            self.run_settings = split_settings(settings, self.info, backend_info)
            parsed = self.run_settings[1]
            if self.reach_ball is not None and any(k == "robot" or k.startswith("robot.") for k in settings):
                # lazy: loads numpy, which importing this module does not
                from ..robot.spec import resolve  # the chosen robot's reach, computed from its chain

                robot = resolve(settings.get("robot"), settings)
                self.reach_ball, self.robot_name = robot.reach(), f"the {robot.name}"
        self.declared = self.info.declared(parsed)

    # ------------------------------------------------------------------ names
    def _known(self, kind: str, name: str, pos: A.Pos) -> None:
        d = self.declared
        if d is None:
            return
        names = d.questions if kind == "question" else d.events
        if name in names:
            return
        hint = did_you_mean(name, names)
        if hint is None:
            hint = f"its {kind}s: {', '.join(sorted(names))}" if names else (d.advice or f"it has no {kind}s")
        raise self.error(f"{d.source or f'world {self.world!r}'} has no {kind} '{name}'", pos, hint)

    def _arguments(self, kind: str, name: str, count: int | None, pos: A.Pos) -> None:
        """``count`` arguments given to a question or event whose table says how many it takes."""
        d = self.declared
        wanted = None if d is None or count is None else d.arities.get((kind, name))
        if wanted is None or wanted == count:
            return
        entry = getattr(self.info, "questions" if kind == "question" else "events").entry(name)
        signature = entry.signature if entry is not None else name
        verb = "ask" if kind == "question" else "wait"
        raise self.error(f"{kind} '{name}' of {d.source or f'world {self.world!r}'} takes "
                         f"{wanted} argument(s), got {count}", pos, f"write it {verb} {signature}")

    def question(self, name: str, pos: A.Pos, count: int | None = None) -> None:
        """``ask name`` with ``count`` arguments (None: not counted)."""
        self._known("question", name, pos)
        self._arguments("question", name, count, pos)

    def event(self, name: str, pos: A.Pos, count: int | None = None) -> None:
        """``wait name`` with ``count`` arguments (None: not counted)."""
        self._known("event", name, pos)
        self._arguments("event", name, count, pos)

    def point(self, name: str, pos: A.Pos) -> None:
        """A world point written out in full (not a program point or a variable)."""
        d = self.declared
        if d is None or d.points is None or name in d.points:
            return
        if any(p.startswith(name + ".") for p in d.points):  # a group: c.* or cell = board.cell5
            return
        head, _, attr = name.rpartition(".")
        if attr in ("x", "y", "z") and head in d.points:
            return
        hint = did_you_mean(name, d.points) or (
            f"it has {len(d.points)} point(s)" if d.points else d.advice or "it names no points")
        raise self.error(f"unknown scene point '{name}' ({d.source or 'the world'} does not name it)", pos, hint)

    # ------------------------------------------------------------------ the arm's reach
    def reach(self, ref: str, icp: str, value: A.Expr, points: dict, variables, pos: A.Pos, via: str = "") -> None:
        """ICP ``icp`` of ``ref`` bound to ``value``: refused when it is a point known now (written
        out, or a program point; ``variables`` are names that shadow program points) outside the
        back end's reach bound."""
        self._reachable(f"ICP '{icp}' of '{ref}' is bound to", value, points, variables, pos, via)

    def reach_via(self, value: A.Expr, points: dict, variables, pos: A.Pos) -> None:
        """A ``via`` waypoint the route must pass: refused like a bound target."""
        self._reachable("the 'via' waypoint is", value, points, variables, pos, "")

    def _reachable(self, what: str, value: A.Expr, points: dict, variables, pos: A.Pos, via: str) -> None:
        if self.reach_ball is None:
            return
        target = constant_point(value, points, variables)
        if target is None or len(target) != 3:
            return
        # lazy: loads numpy, which importing this module does not
        from ..robot.reach import out_of_reach

        why = out_of_reach(target, *self.reach_ball)
        if why is not None:
            where = "(" + ", ".join(f"{v:.3f}" for v in target) + ")"
            raise self.error(f"{what} {where}{via}, which the arm cannot reach: {why}", pos,
                             f"back end {self.backend_name!r} moves {self.robot_name}'s arm: targets must be above the table, "
                             "in front of the robot (x 0.20-0.45 m, y -0.30-0.10 m works at table height)")

    # ------------------------------------------------------------------ moving scenes
    def track(self, pos: A.Pos) -> None:
        """A ``track`` clause: refused unless the world can be tracked and the back end streams."""
        if not self.info.tracking:
            can = [w.name for w in registry.declarations("world") if w.tracking]
            raise self.error(f"'track' needs a world that shows the robot its points again while a step runs; world "
                             f"'{self.world}' cannot: it tells its points only between steps", pos,
                             "remove the 'track' clause" + (f", or run in a world that can ({', '.join(can)})"
                                                            if can else ""))
        if not self.backend_streams:
            can = [b.name for b in registry.declarations("back end") if b.streaming]
            raise self.error(f"'track' needs a back end that can change the path it follows while the arm moves; back "
                             f"end '{self.backend_name}' cannot: it takes a whole path and runs it to the end", pos,
                             (f"run it with --backend {' or '.join(can)}, or " if can else "") + "remove the 'track' clause")

    # ------------------------------------------------------------------ dimensions
    def value_dim(self, kind: str, name: str) -> int | None:
        """The size of the point a question (``kind="question"``) or event always answers, or None."""
        d = self.declared
        if d is None:
            return None
        return (d.question_dims if kind == "question" else d.event_dims).get(name)

    def binding(self, ref: str, dim: int, icp: str, value_dim: int | None, pos: A.Pos, via: str = "") -> None:
        """ICP ``icp`` of the ``dim``-D template ``ref`` bound to a point of ``value_dim``
        coordinates (None: not known before the run); ``via``: how it got there (a parameter)."""
        if dim == 2 and value_dim is not None and value_dim != 3:
            raise self.error(f"ICP '{icp}' of the 2-D template '{ref}' is bound to a {value_dim}-D point{via}", pos,
                             "bind it to a point of the world (x, y, z): a 2-D template runs on the world's "
                             "drawing surface, and the points bound to it are projected onto the surface")
        if dim == 3 and value_dim is not None and value_dim != 3:
            raise self.error(f"ICP '{icp}' of the 3-D template '{ref}' is bound to a {value_dim}-D point{via}", pos,
                             "give the point 3 coordinates (x, y, z), metres")

    def drawn(self, ref: str, template, pos: A.Pos) -> None:
        """A pen-down (sub-)template ``ref`` the program draws with: refused where the world says
        it cannot play it (its ``mark_check``)."""
        why = self.info.check_mark(ref, template)
        if why is not None:
            raise self.error(why, pos, "teach the robot a mark that looks unlike the opponent's cross (a circle, a "
                                       "triangle, a tick, a square, a letter ...): it reads its marks by their shape, "
                                       "whatever their turn and size")

    def template(self, ref: str, dim: int, pos: A.Pos) -> None:
        """A ``dim``-D template run in this world."""
        if dim != 2:
            return
        d = self.declared
        if not (d.drawing_surface if d is not None else self.info.drawing_surface):
            worlds = [w.name for w in registry.declarations("world") if w.drawing_surface]
            raise self.error(
                f"'{ref}' is a 2-D template, and world '{self.world}' has no drawing surface to run it on", pos,
                "a 2-D template is a drawing: run it in a world with paper"
                + (f" ({', '.join(worlds)})" if worlds else "") + ", or learn the demonstration in 3-D")


def constant_point(expr, points: dict, variables=(), depth: int = 0) -> tuple[float, ...] | None:
    """The coordinates of ``expr`` when they are known before the run: a point written out
    (``(1.0, -0.2, 0.6)``, signs allowed) or a program point (``point far = ...``) that is one,
    not shadowed by a variable; None otherwise (a question's answer, a parameter, a sum)."""
    if depth > 50:
        return None
    if isinstance(expr, A.Number) and not isinstance(expr.value, bool):
        return (float(expr.value),)
    if isinstance(expr, A.Unary) and expr.op == "-":
        inner = constant_point(expr.operand, points, variables, depth + 1)
        return None if inner is None or len(inner) != 1 else (-inner[0],)
    if isinstance(expr, A.Vector):
        items = [constant_point(e, points, variables, depth + 1) for e in expr.items]
        if any(i is None or len(i) != 1 for i in items):
            return None
        return tuple(i[0] for i in items)
    if isinstance(expr, A.Name) and len(expr.parts) == 1 and expr.parts[0] not in variables:
        value = points.get(expr.parts[0])
        return None if value is None else constant_point(value, points, variables, depth + 1)
    return None
