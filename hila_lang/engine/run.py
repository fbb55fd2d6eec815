"""The executor of ``run`` states: one HILA step (bind a sub-template's ICPs in the scene, warp it
with OSILA, move the hand along it).

A ``run`` state evaluates its bindings against the scene (variables, ``hand`` = where the back end
says the hand is, the program's ``point`` s, then the world's ``points()``), warps the
(sub-)template with :func:`hila_lang.hierarchy.step.hila_step` (the one HILA step, shared with
``hila imitate`` and ``hila eval --hila``: its ``start`` ICP bound to the hand unless the program
binds it), moves the back end along the path, and calls
``world.notify("state_done", state=, path=, executed=, kind="run", pen_down=, icps=, template=)``
(``template`` is the sub-template that ran; a streamed run adds ``replans=``); before the run,
``world.notify("program", marks=)`` names every pen-down (sub-)template the program can run (what
the robot draws with, so a world can know its marks; :meth:`hila_lang.engine.interpreter.Interpreter`).  Its ``via``/``avoid`` constraints (and those of the
task calls around it) are evaluated now (:meth:`RunExecutor.constraints`: a point group gives one
per point) and go to OSILA's plan adjustment through the same step; the trace says how each was
met.  A run with a ``track`` clause (or any run while the world's scene moves during steps) is
streamed instead of moved in one go: :func:`hila_lang.engine.tracking.follow` keeps its tracked
ICPs live and warps the rest of the step again when they move; each re-plan is a line of its
trace text and a :class:`~hila_lang.engine.tracking.Replan` in ``TraceEntry.replans``.

**A free end is pulled into reach.**  Where no bound ICP places a step's end (its ``end``
unbound and the ICP it heads for bound to ``none``, e.g. game.hila's final ``run
circle.retract(last.*, hand = none)``), the end goes where the demonstration went, which need not
be where this arm reaches (a drawn retract that heads towards the robot, run from a near cell).
When the back end refuses the move (:class:`~hila_lang.core.errors.UnreachableError`: its own
reach bound and IK, what the robot knows of its arm; the arm did not move) at a waypoint of that
free tail (:func:`hila_lang.hierarchy.step.free_tail`), :meth:`RunExecutor.move` shrinks the
whole free tail towards the last waypoint the bound ICPs place (the tail's shape kept, its length
times :data:`PULL` at each try) and asks again, at most :data:`PULLS` times; the trace says so
(``note: the free end ... pulled``).  A waypoint a bound ICP places is never moved: out of
reach, it stays the located error; nor is a pen-down path (what it draws is the mark).  ``hila
check`` notes a free end before the run (:meth:`hila_lang.language.checker._Checker.free_end`).
"""

from __future__ import annotations

import numpy as np

from ..core.errors import HilaRuntimeError, UnreachableError
from ..hierarchy.explain import explain_run, explain_step
from ..hierarchy.step import bind, Constraint, free_tail, hila_step
from ..language import ast as A
from ..language.fsm import RunState, State
from .executors import executes, Executor
from .scene import src
from .trace import fmt_point, fmt_value, met_text, TraceEntry
from .tracking import follow, streams

START, END = "start", "end"
#: how much of its length a free tail keeps at each pull towards the last waypoint the bound ICPs
#: place, and at most how many pulls (0.8 ** 20 = 1 %: the tail all but folded onto that waypoint)
PULL, PULLS = 0.8, 20


@executes(RunState)
class RunExecutor(Executor):
    """Runs ``run`` states; keeps the (sub-)templates it has cut, until the program is reloaded."""

    def __init__(self, ctx) -> None:
        super().__init__(ctx)
        self._subs: dict = {}

    def reload(self) -> None:
        self._subs.clear()

    def template(self, st: State):
        """The (sub-)template a run state runs."""
        key = (st.template, st.tag)
        if key not in self._subs:
            t = self.ctx.checked.templates[st.template]
            self._subs[key] = t if st.tag is None else t.sub(st.tag)
        return self._subs[key]

    def surface(self):
        """The world's drawing surface (its scene's), where 2-D templates run; or None."""
        scene = self.ctx.world.scene
        return None if scene is None else scene.surface

    def scene_binding(self, st) -> dict[str, np.ndarray | None]:
        """What a run state's bindings say now: ICP name -> point, or None (``icp = none``).

        ``start`` appears only when the program binds it; :func:`hila_lang.hierarchy.step.hila_step`
        binds it to the hand otherwise.
        """
        t, scene = self.template(st), self.ctx.scene
        icps = [k for k in t.icps if k not in (START, END)]
        out: dict[str, np.ndarray | None] = {}
        spread = None
        points = None  # the world's points, asked once for all of a group's names

        def lookup(name: str):
            nonlocal points
            if points is None:
                points = scene.world.points()
            return scene.lookup(name, points)

        for icp, expr in st.bindings:
            if icp == A.SPREAD:
                spread = expr
            elif icp in t.icps:
                out[icp] = scene.point(expr, allow_none=True)
            else:  # a group prefix: icp.K <- value.K
                prefix = scene.reference(expr)
                for k in t.icps:
                    if k.startswith(icp + "."):
                        out[k] = lookup(f"{prefix}.{k[len(icp) + 1:]}")
        if spread is not None:
            prefix = scene.reference(spread)
            for k in icps:
                if k not in out:
                    out[k] = lookup(f"{prefix}.{k}")
        return out

    def bind(self, st) -> dict[str, np.ndarray]:
        """Task ICPs of a run state: name -> point (3,), in the template's ICP order (a 2-D
        template's as bound in the scene, before they are projected onto the drawing surface)."""
        t, binding, hand = self.template(st), self.scene_binding(st), self.ctx.scene.hand()
        if t.dim == 2 and self.surface() is not None:
            given = {START: hand, **binding}
            return {k: given[k] for k in t.icps if given.get(k) is not None}
        return bind(t, binding, hand)

    def constraints(self, st) -> list:
        """A run state's ``via``/``avoid`` as named :class:`hila_lang.hierarchy.step.Constraint` s, now:
        a point group gives one per point; a radius must be a number > 0 (metres)."""
        scene, out = self.ctx.scene, []
        for c in st.constraints:
            where = f"{c.text()} at {c.pos.line}:{c.pos.column}" if c.pos.line else c.text()
            radius = None
            if c.radius is not None:
                radius = scene.eval(c.radius)
                if isinstance(radius, bool) or not isinstance(radius, (int, float)) or not radius > 0:
                    raise HilaRuntimeError(f"an obstacle's radius must be a number of metres > 0, got "
                                           f"{fmt_value(radius)} from '{src(c.radius)}' in '{where}'")
            for member, point in scene.points_of(c.value):
                name = where if member is None else f"{where} ({member})"
                out.append(Constraint(point, None if radius is None else float(radius), name))
        return out

    def execute(self, st, n: int) -> TraceEntry:
        ctx, t = self.ctx, self.template(st)
        binding = self.scene_binding(st)
        step = hila_step(t, binding, ctx.scene.hand(), constraints=self.constraints(st),
                         surface=self.surface(), **ctx.osila_options)
        path, icps, notes = step.path, step.icps, list(step.notes)
        replans = None
        try:
            if streams(ctx, st):
                followed = follow(self, st, t, step, binding)
                path, executed, replans = followed.path, followed.executed, followed.replans
            else:
                executed, path, pulled = self.move(st, t, step)
                notes = notes + ([pulled] if pulled else [])
        except UnreachableError as exc:  # told as the program's target, not a waypoint index
            # lazy: only this branch needs it
            from ..robot.reach import name_the_target

            raise name_the_target(exc, icps, st.ref) from None
        executed = None if executed is None else np.asarray(executed, dtype=float)
        ctx.hold()
        extra = {} if replans is None else {"replans": replans}
        ctx.world.notify("state_done", state=st.name, path=path, executed=executed, kind="run",
                         pen_down=bool(st.pen_down), icps=dict(icps), template=t, **extra)
        text = (f"run {st.ref} pen {'down' if st.pen_down else 'up'}: {len(path)} points "
                f"{fmt_point(path[0])} -> {fmt_point(path[-1])}; icps "
                + " ".join(f"{k}={fmt_point(v)}" for k, v in icps.items()) + met_text(step, executed))
        text += "".join(f"; note: {note}" for note in notes)
        if st.track is not None:
            text += f"; tracked {', '.join(A.source_text(n) for n in st.track.names)}: {len(replans)} re-plan(s)"
            text += "".join("\n      " + r.text() for r in replans)
        return TraceEntry(n, st.name, "run", st.line, text, st.next, path=path, executed=executed,
                          icps=icps, pen_down=bool(st.pen_down), step_result=step, replans=replans)

    def move(self, st, t, step) -> tuple:
        """Move the back end along ``step.path``; a free end out of reach pulled in (module
        docstring).  Returns ``(executed, path moved along, note or None)``; raises the back end's
        first :class:`UnreachableError` when the waypoint refused is not in the free tail, or
        the pulls do not bring it into reach."""
        backend, path = self.ctx.backend, np.asarray(step.path, dtype=float)
        first, tail, pulls = None, None, 0
        while True:
            try:
                executed = backend.move(path, pen_down=bool(st.pen_down), label=st.name)
                break
            except UnreachableError as exc:
                first = first or exc
                point = getattr(exc, "point", None)
                if tail is None:
                    tail = free_tail(t, step.icps) if len(path) == len(t.path) else None
                k = None if point is None else int(np.argmin(np.linalg.norm(path - point, axis=1)))
                # not tail: none, or 0 (no waypoint the bound ICPs place to pull towards)
                if k is None or not tail or k < tail or pulls == PULLS or st.pen_down:
                    raise first from None
                pulls += 1
                path = path.copy()
                anchor = step.path[tail - 1]
                path[tail:] = anchor + PULL ** pulls * (step.path[tail:] - anchor)
        if first is None:
            return executed, path, None
        moved = float(np.linalg.norm(path[-1] - step.path[-1]))
        free = ", ".join([f"{k} = none" for k in t.icps if k not in step.icps and k != END] + ["end unbound"])
        return executed, path, (
            f"the free end of '{st.ref}' (waypoints {tail + 1}-{len(path)} of {len(path)}, placed by no bound ICP: "
            f"{free}) left the arm's reach (cannot reach {fmt_point(first.point)} m: {first.reason}); pulled into reach in {pulls} "
            f"step(s) of {PULL:g} (to {PULL ** pulls:.0%} of its length): it ends at {fmt_point(path[-1])}, "
            f"{moved * 1000:.1f} mm from {fmt_point(step.path[-1])} where the demonstration went")

    def explain(self, st, title: str) -> list[str]:
        """What OSILA will do in run state ``st`` (:func:`hila_lang.hierarchy.explain.explain_run`)."""
        return explain_run(self.template(st), self.scene_binding(st), self.ctx.scene.hand(), self.constraints(st),
                           self.ctx.osila_options, surface=self.surface(), title=title)

    def explain_done(self, st, entry: TraceEntry, title: str) -> list[str]:
        """What OSILA did in a run ``entry`` of state ``st`` (:func:`hila_lang.hierarchy.explain.explain_step`)."""
        return explain_step(self.template(st), entry.step_result, title=title)
