"""THE HILA step: bind a (sub-)template to scene points and the hand (:func:`bind`), run OSILA,
begin exactly at the hand (:func:`hila_step`).

The interpreter runs every ``run`` state through it; :func:`hila_lang.hierarchy.generate.generate`
(``hila imitate``, ``hila eval --hila``) runs every step of a sequence through it, so the same step
makes the same path in every command.  Also here: named constraints (:class:`Constraint`), a
surface's points, the reasons a step is blocked, and a step's free end (:func:`free_tail`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

import numpy as np

from ..core.errors import ConstraintError, InputError
from ..core.validation import check_points
from ..osila import imitate_detailed, obstacle_spheres
from ..osila.pairs import Pairs
from ..osila.template import END, START, Template


@dataclass(frozen=True)
class Constraint:
    """A forced waypoint (``radius`` None: the route passes within OSILA's threshold of ``point``)
    or an obstacle (a sphere of ``radius`` around ``point``: the route keeps out), named as the
    user wrote it, e.g. ``"via waypoint [line 5:42]"``.

    Attributes
    ----------
    point : ndarray, shape (D,)
    radius : float or None
        Metres (task units).
    name : str
    """

    point: np.ndarray
    radius: float | None = None
    name: str = ""

    @property
    def kind(self) -> str:
        return "via" if self.radius is None else "avoid"

    def achieved(self, path: np.ndarray) -> float:
        """How the route ``path`` (T, D) meets it: for a waypoint, its distance to the route's
        nearest waypoint; for an obstacle, the clearance (distance of the route's polyline from the
        centre minus the radius; negative: it enters)."""
        p = np.asarray(path, dtype=float)
        if self.radius is None:
            return float(np.sqrt(((p - self.point) ** 2).sum(1)).min())
        return float(_polyline_distance(p, self.point)) - self.radius


def _polyline_distance(path: np.ndarray, point: np.ndarray) -> float:
    """Distance from ``point`` (D,) to the polyline through ``path`` (T, D)."""
    if len(path) == 1:
        return float(np.linalg.norm(path[0] - point))
    a, b = path[:-1], path[1:]
    ab = b - a
    den = (ab * ab).sum(1)
    u = np.clip(np.where(den > 0, ((point - a) * ab).sum(1) / np.where(den > 0, den, 1.0), 0.0), 0.0, 1.0)
    return float(np.sqrt((((a + u[:, None] * ab) - point) ** 2).sum(1)).min())


_FORCED_LABEL = re.compile(r"forced waypoint (\d+) at \([^)]*\)")
_OBSTACLE_LABEL = re.compile(r"obstacle (\d+) \(centre \([^)]*\), radius [^,)]*(?:, margin ([^)]*))?\)")


def violations(message: str) -> str:
    """The violated constraints of OSILA's "could not conform" ``message`` (the whole message
    when it is worded otherwise)."""
    m = re.search(r"could not conform after \d+ round\(s\): (.*?)(?:\. Constraint pairs tried:|$)", message, re.S)
    return m.group(1) if m else message


def name_constraints(message: str, forced: Sequence[Constraint], obstacles: Sequence[Constraint]) -> str:
    """OSILA's ``message`` with its labels ``forced waypoint i at (...)`` and ``obstacle o (centre
    ..., radius r)`` replaced by the names of ``forced[i]`` and ``obstacles[o]`` (labels beyond
    them are left as they are).  The one place that reads OSILA's wording."""
    def forced_name(m):
        i = int(m.group(1))
        return forced[i].name if i < len(forced) and forced[i].name else m.group(0)

    def obstacle_name(m):
        o = int(m.group(1))
        if o >= len(obstacles) or not obstacles[o].name:
            return m.group(0)
        margin = m.group(2)
        extra = f" (with margin {margin})" if margin is not None and float(margin) != 0 else ""
        return obstacles[o].name + extra

    return _OBSTACLE_LABEL.sub(obstacle_name, _FORCED_LABEL.sub(forced_name, message))


@dataclass
class Step:
    """One HILA step: a (sub-)template imitated against bound scene points.

    Attributes
    ----------
    path : ndarray, shape (T, D)
        The generated path; it begins exactly at the hand when ``"start"`` was bound.
    icps : Pairs
        The ICP pairs used (:class:`hila_lang.osila.Pairs`): a mapping name -> task point (D,),
        in the template's ICP order, with the template points OSILA paired them with.
    start_bound : bool
        Whether the template's ``"start"`` ICP was bound (to the hand, or by the caller).
    result : OsilaResult
        What OSILA did (warp kind, threshold, rounds, added constraint pairs).
    constraints : tuple of Constraint
        The named constraints it met (forced waypoints, obstacles).
    notes : list of str
        What a user should know about the step: a binding not used (:func:`check_coincident`).
    """

    path: np.ndarray
    icps: Pairs
    start_bound: bool
    result: Any
    constraints: tuple = ()
    options: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def met(self, path=None) -> list[tuple[Constraint, float]]:
        """Each named constraint with :meth:`Constraint.achieved` on ``path`` (default: the
        planned path; a run passes where the hand went)."""
        path = self.path if path is None else path
        return [(c, c.achieved(path)) for c in self.constraints]


def _fmt(p) -> str:
    return "(" + ", ".join(f"{(0.0 if abs(v) < 5e-4 else v):.3f}" for v in np.asarray(p, float)) + ")"


def bind(template: Template, task_icps: Mapping[str, Any], hand: Any = None) -> Pairs:
    """The ICP pairs of one step (:class:`hila_lang.osila.Pairs`, name -> task point (D,)), in the
    template's ICP order: the one place a template's ICPs take the shape OSILA takes.

    ``task_icps`` maps ICP names to points; a value of None leaves that ICP out on purpose, and
    every scene ICP of the template must be named.  ``"start"`` is ``task_icps["start"]`` when
    given, else ``hand``; ``"end"`` only when given.  Raises :class:`InputError` for a missing
    scene ICP, a point of the wrong size, or nothing bound at all.
    """
    D = template.dim
    missing = [n for n in template.icps if n not in (START, END) and n not in task_icps]
    if missing:
        raise InputError(f"task gives no ICP {missing[0]!r}; template has {', '.join(template.icps)}; "
                         f"task gives {', '.join(task_icps) or 'none'}")
    names, src, dst = [], [], []
    for name, at in template.icps.items():
        point = hand if name == START and START not in task_icps else task_icps.get(name)
        if point is None:
            continue
        arr = np.asarray(point, dtype=float).reshape(-1)
        if arr.shape != (D,):
            raise InputError(f"template '{template.name}' is {D}-D but ICP '{name}' is bound to the "
                             f"{arr.size}-D point {_fmt(arr)}")
        names.append(name)
        src.append(at)
        dst.append(check_points(arr, D, f"ICP {name!r}")[0])
    if not names:
        raise InputError(f"no ICP of '{template.name}' is bound; bind at least one "
                         f"(it has {', '.join(template.icps) or 'none'})")
    return Pairs(tuple(names), np.array(src, dtype=float), np.array(dst, dtype=float))


def hila_step(template: Template, task_icps: Mapping[str, Any], hand: Any = None, *, forced: Any = None,
              obstacles: Any = None, constraints: Sequence[Constraint] = (), surface: Any = None,
              **options: Any) -> Step:
    """THE HILA step: bind a (sub-)template to scene points and the hand, run OSILA.

    The interpreter (every ``run`` state of ``hila exec``/``hila repl``), ``hila imitate`` and
    ``hila eval --hila`` (through :func:`generate`) all generate a step here, so the same step
    gives the same path everywhere.

    Binding is :func:`bind`.  A bound ``"start"`` pins the first stamp to that exact point and a
    bound ``"end"`` the last (OSILA's ``pin={0: start, -1: end}``; a pin wins over another
    template ICP at the same template point, so a sub-template that begins at an object it
    touched still begins exactly at the hand).  A caller's own ``pin`` replaces these.

    Two ICPs at the same template point bound to different task points cannot both hold (OSILA
    keeps one pair per template point): the hand's ``start`` wins with a note in ``Step.notes``,
    any other pair is an :class:`InputError` naming both (:func:`check_coincident`); a binding is
    never dropped in silence.  When OSILA cannot avoid an
    obstacle because it covers a bound ICP the path passes through, the
    :class:`~hila_lang.core.errors.ConstraintError` says so (:func:`explain_blocked`).

    A 2-D template on a 3-D scene runs on ``surface`` (a drawing surface: ``to_local`` and
    ``to_world``, e.g. :class:`hila_lang.sim.surface.Surface`): the bound points and the hand are
    projected onto it, OSILA runs in its plane, and the path is lifted back onto it (see
    :func:`on_surface`).

    Parameters
    ----------
    template : Template
        Usually a sub-template (:meth:`Template.sub`), which carries ``"start"``/``"end"``.
    task_icps : mapping name -> (D,) or None
        Scene points for the template's ICPs (metres); None leaves one out.
    hand : array_like, shape (D,), optional
        Where the hand is: binds ``"start"`` unless ``task_icps`` names it.
    forced, obstacles, **options
        As :func:`hila_lang.osila.imitate`.
    constraints : sequence of Constraint
        Named forced waypoints and obstacles (a program's ``via`` and ``avoid``), given to OSILA's
        plan adjustment before ``forced`` and ``obstacles``.  When they cannot be met, the
        :class:`~hila_lang.core.errors.ConstraintError` names them as the user wrote them.
    surface : drawing surface, optional
        Where a 2-D template runs when the scene is 3-D.

    Returns
    -------
    Step
    """
    named_forced = [c for c in constraints if c.radius is None]
    named_obstacles = [c for c in constraints if c.radius is not None]
    flat = template.dim == 2 and three_d(task_icps, hand)
    dim = 3 if flat else template.dim  # a 2-D template on a 3-D scene: constraints are scene points
    if named_forced:
        forced = _named(named_forced, forced, "forced", template, dim)
    if named_obstacles:
        obstacles = _named(named_obstacles, obstacles, "obstacles", template, dim)
    try:
        if flat:
            step = on_surface(template, task_icps, hand, surface, forced=forced, obstacles=obstacles, **options)
        else:
            step = _step(template, task_icps, hand, forced, obstacles, options)
    except ConstraintError as exc:
        if constraints:
            exc.message = name_constraints(exc.message, named_forced, named_obstacles)
            exc.args = (exc.message,)
        raise
    return replace(step, constraints=tuple(constraints))


def _step(template: Template, task_icps: Mapping[str, Any], hand: Any, forced: Any, obstacles: Any,
          options: dict) -> Step:
    """Bind, then OSILA with the bound start and end pinned (the plain step of :func:`hila_step`)."""
    icps, notes = check_coincident(template, bind(template, task_icps, hand), task_icps, options.get("threshold"))
    options = dict(options)
    if icps.pins():
        options.setdefault("pin", icps.pins())
    try:
        res = imitate_detailed(template.path, icps.src, icps.dst, forced=forced, obstacles=obstacles, **options)
    except ConstraintError as exc:
        exc.message = icps.renamed(exc.message)  # OSILA's rows by name
        exc.args = (exc.message,)
        raise explain_blocked(exc, template, icps, obstacles, options) from None
    given = {k: v for k, v in options.items() if k != "pin"}
    return Step(np.asarray(res.path, dtype=float), icps, START in icps, res, options=given, notes=notes)


#: a step's end is free when it lies farther than this fraction of its path's extent (from its
#: first point) from every bound ICP (:func:`free_tail`): the checker's measure of an ICP the path
#: never comes near (:data:`hila_lang.language.checker.REMOTE_ICP`).  The shipped circle's reach
#: ends 0.10 of its extent from a corner, its retract 0.88 (and a person's drawn retracts 0.8-0.9)
FREE_END = 0.5


def free_tail(template: Template, icps: Pairs) -> int | None:
    """Where a step's free end begins, or None when its end is bound.

    The end is bound when ``"end"`` is among ``icps``, or a bound ICP's template point
    (``icps.src``, the hand's ``start`` included) lies within :data:`FREE_END` of the path's
    extent of the path's last point: the bound points place it.  Otherwise the free tail is the
    longest tail of ``template.path`` (T, D) whose template points all lie nearer the last point
    than any bound ICP's: no bound ICP places those waypoints, the demonstration alone says
    where they go (e.g. game.hila's retract run with ``hand = none``), so the engine may pull them
    into the arm's reach (:meth:`hila_lang.engine.run.RunExecutor.move`) and ``hila check`` warns.
    Returns the tail's first index.
    """
    if END in icps.names or not len(icps):
        return None
    path = np.asarray(template.path, dtype=float)
    extent = float(np.linalg.norm(path - path[0], axis=1).max())
    to_end = np.linalg.norm(path - path[-1], axis=1)
    to_bound = np.linalg.norm(path[:, None, :] - icps.src[None, :, :], axis=2).min(axis=1)
    if extent == 0 or to_bound[-1] <= FREE_END * extent:
        return None
    k = len(path)
    while k > 0 and to_end[k - 1] < to_bound[k - 1]:
        k -= 1
    return k


def three_d(task_icps: Mapping[str, Any], hand: Any) -> bool:
    """Whether any bound point (or the hand) has 3 coordinates."""
    points = [v for v in task_icps.values() if v is not None] + ([] if hand is None else [hand])
    return any(np.asarray(p, dtype=float).size == 3 for p in points)


def surface_points(template: Template, surface: Any):
    """``local(point)``: a scene point (3,) projected onto the drawing surface where a 2-D
    template runs, in the surface's plane (2,) (InputError for a missing surface or a point that
    is not (x, y, z))."""
    if surface is None:
        raise InputError(f"'{template.name}' is a 2-D template, and this world has no drawing surface to run "
                         "it on: run it in a world with paper, or learn the demonstration in 3-D")

    def local(p):
        arr = np.asarray(p, dtype=float).reshape(-1)
        if arr.size != 3:
            raise InputError(f"the 2-D template '{template.name}' runs on the drawing surface: bind its ICPs to "
                             f"points of the world (x, y, z), got the {arr.size}-D point {_fmt(arr)}")
        return np.asarray(surface.to_local(arr), dtype=float)

    return local


def on_surface(template: Template, task_icps: Mapping[str, Any], hand: Any, surface: Any, *,
               forced: Any = None, obstacles: Any = None, **options: Any) -> Step:
    """A 2-D template run on a drawing surface of a 3-D scene.

    The bound points, the hand, forced waypoints and obstacle centres (3-D, metres) are
    projected straight down onto the surface (``surface.to_local``: its right and far axes);
    OSILA warps the template in that plane; the path is lifted back onto the surface
    (``surface.to_world``), so it lies on the paper, z = the surface's top.  The step's ICPs are
    the projected points, on the paper.  A 2-D template is a drawing: it has no height to warp.
    """
    local = surface_points(template, surface)
    flat = {k: None if v is None else local(v) for k, v in task_icps.items()}
    flat_forced = None if forced is None else np.array([local(f) for f in np.asarray(forced, float).reshape(-1, 3)])
    flat_obstacles = None
    if obstacles is not None:
        # lazy: only this branch needs it
        from ..osila import obstacle_spheres  # the one reader of obstacle specs (3-D here)

        spheres = obstacle_spheres(obstacles, 3)
        flat_obstacles = np.column_stack([np.array([local(c) for c in spheres[:, :3]]).reshape(-1, 2),
                                          spheres[:, 3]])
    step = _step(template, flat, None if hand is None else local(hand), flat_forced, flat_obstacles, options)

    def lift(points):
        points = np.asarray(points, dtype=float)
        return np.asarray(surface.to_world(points[..., 0], points[..., 1]), dtype=float)

    return replace(step, path=lift(step.path), icps=step.icps.mapped(lift))


def check_coincident(template: Template, icps: Pairs, given: Mapping[str, Any],
                     threshold: float | None = None) -> tuple[Pairs, list[str]]:
    """ICPs that are one point of the template but bound to different task points
    (:meth:`Pairs.coincident <hila_lang.osila.pairs.Pairs.coincident>`), and what becomes of them.

    OSILA keeps one pair per template point, so one of the bindings would be dropped and the path
    would ignore it -- never in silence here:

    - ``start`` bound to the hand by default wins (a step begins where the hand is): the other
      ICP is taken out of the pairs returned and a note says so (returned, for the trace);
    - any other pair (both bound by the caller) is an :class:`InputError` naming both.

    Points closer than the distortion threshold (given, else 1 % of the template path's size)
    are one point for the route anyway and pass.  ``given``: what the caller bound by name (a
    ``start`` missing from it is the hand).
    """
    notes: list[str] = []
    hand_start = START in icps and START not in given
    for a, b, gap in icps.coincident(template.path, threshold):
        if a not in icps or b not in icps:
            continue
        if hand_start and START in (a, b):
            other = b if a == START else a
            notes.append(f"'{other}' is where '{template.name}' starts in the demonstration; the step starts "
                         f"where the hand is, {gap:.3g} from {other} = {_fmt(icps[other])}, so that binding is "
                         f"not used (bind {other} = none to say so)")
            icps = icps.without(other)
            continue
        raise InputError(
            f"ICPs '{a}' and '{b}' of '{template.name}' are one point in the demonstration but are bound "
            f"{gap:.3g} apart: {a} = {_fmt(icps[a])}, {b} = {_fmt(icps[b])}; the warp maps one point to one "
            "place only", hint=f"bind one of them to none (e.g. {b} = none), or both to the same point")
    return icps, notes


def explain_blocked(exc, template: Template, icps: Pairs, obstacles: Any, options) -> Exception:
    """``exc`` (OSILA's ConstraintError) with what can help when an obstacle covers an ICP the
    path passes through (its start, a touched object): no threshold or number of rounds gets
    the route out, the obstacle or the binding has to change."""
    if obstacles is None or not len(icps):
        return exc
    spheres = obstacle_spheres(obstacles, template.dim)
    margin = float(options.get("margin") or 0.0)
    through = icps.through(template.path)
    covered = []
    for name, point in icps.items():
        for o, sphere in enumerate(spheres):
            if name in through and np.linalg.norm(point - sphere[:-1]) < sphere[-1] + margin:
                covered.append(f"ICP '{name}' at {_fmt(point)} lies inside obstacle {o} "
                               f"(centre {_fmt(sphere[:-1])}, radius {sphere[-1]:.4g})")
    if not covered:
        return exc
    return ConstraintError(
        f"the path must pass through ICPs that an obstacle covers: {'; '.join(covered)}",
        hint="move or shrink the obstacle, or bind that ICP elsewhere (or to none); raising 'rounds' or "
             "'threshold' cannot help")


def _named(constraints: list, given: Any, what: str, template: Template, dim: int) -> np.ndarray:
    """Named constraints as OSILA's array: points (N, dim), or spheres (N, dim + 1) for obstacles."""
    if given is not None:
        raise InputError(f"expected {what} either as named constraints or as the '{what}' argument, got both")
    rows = []
    for c in constraints:
        point = np.asarray(c.point, dtype=float).reshape(-1)
        if point.shape != (dim,):
            raise InputError(f"template '{template.name}' runs in {dim}-D but {c.name or c.kind} is the "
                             f"{point.size}-D point {_fmt(point)}")
        rows.append(point if c.radius is None else np.append(point, c.radius))
    return np.array(rows, dtype=float)
