"""AST -> checked program: imports resolved, every name known, every ICP bound.

:func:`check` raises :class:`~hila_lang.core.errors.CheckError` (exit 2) at the first mistake, with
the source position, the source line and a "did you mean" where one helps.  What it checks:

- the world is a registered plug-in (:mod:`hila_lang.plugins.registry`); each import resolves to
  a readable template (``import NAME`` along :func:`hila_lang.core.resources.template_search_path`:
  ``HILA_PATH``, the program's folder, the package's own); aliases, tasks,
  points and parameters are unique; there is exactly one ``main``;
- ``run T.TAG(...)``: ``T`` is imported, ``TAG`` is one of its tags, every bound name is an ICP
  of that sub-template (or a group prefix: ``cell`` binds ``cell.tl``, ``cell.tr``, ...), no
  ICP is bound twice, and every scene ICP is bound (``start`` defaults to the hand, ``end`` is
  optional, ``icp = none`` leaves one out on purpose);
- ``run ... track c every N ms [threshold N mm] [blend N mm] [lift above N mm]``: each tracked
  name is known and binds at least one of the run's ICPs, each option is given once and within
  its range (:data:`TRACK_RANGES`), and the world and the back end can follow a moving scene
  (:meth:`~hila_lang.language.worldcheck.WorldCheck.track`);
- task calls name a task, with the right number of arguments, and no task calls itself
  (tasks are compiled inline);
- a plain (undotted) name is a parameter, a ``let`` before it, a ``point``, or ``hand``;
  dotted names whose first part is none of those are world points, checked when the program runs.

Unreachable statements are found by the compiler on the FSM graph (also a CheckError).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.errors import CheckError, did_you_mean, HilaError
from ..plugins import registry
from . import ast as A
from .calls import check_calls
from .fsm import TRACK_THRESHOLD
from .limits import MAX_NESTING
from .loader import TemplateLoader
from .source import source_line
from .worldcheck import WorldCheck

START, END = "start", "end"
#: a bound ICP farther from its (sub-)template's path than this fraction of the path's extent
#: draws a warning (:meth:`_Checker.remote_icp`)
REMOTE_ICP = 0.5


class Diagnostic(str):
    """A warning (or a note): the text ``hila check`` prints (``FILE:LINE:COL: warning: MESSAGE``), with its
    parts kept for tools: ``code`` (a stable name, e.g. ``unused-task``), ``message``, ``pos``
    (the node's :class:`~hila_lang.language.ast.Pos`, start and end) and ``severity``."""

    code: str
    message: str
    pos: A.Pos
    severity: str

    def __new__(cls, code: str, message: str, file: str, pos: A.Pos, severity: str = "warning"):
        self = super().__new__(cls, f"{file}:{pos.line}:{pos.column}: {severity}: {message}")
        self.code, self.message, self.pos, self.severity = code, message, pos, severity
        return self


def loader_of(templates) -> TemplateLoader:
    """``templates`` as a :class:`~hila_lang.language.loader.TemplateLoader`: itself, a new one
    (None), or one that loads with the ``load_template(path)`` callable given."""
    if templates is None:
        return TemplateLoader()
    if isinstance(templates, TemplateLoader):
        return templates
    loader = TemplateLoader()
    loader.load = templates
    return loader
RESERVED = {"hand", "main"}
#: what a ``track`` option may be, in the unit it is written in: (lowest, highest, lowest allowed)
#: -- a tick shorter than PyBullet's control step (1/240 s) would look twice between two moves
TRACK_RANGES = {"every": (5.0, 10000.0, True), "threshold": (0.0, 1000.0, False), "blend": (0.0, 1000.0, True),
                "lift": (0.0, 1000.0, False)}


@dataclass
class CheckedProgram:
    """A program whose names all resolve, with its templates loaded."""

    program: A.Program
    world: str
    templates: dict  # alias -> hila_lang.osila.template.Template
    template_files: dict  # alias -> Path
    tasks: dict  # name -> TaskDef
    main: A.MainDef
    points: dict  # name -> Expr
    hand: A.Expr | None
    warnings: list[Diagnostic] = field(default_factory=list)  # each also its printed text
    #: the ``--set`` pairs it was checked with, parsed: (OSILA options, world settings,
    #: back-end settings); None when checked without them
    run_settings: tuple | None = None


class _Defined(set):
    """The names defined at a point of a body, and the dimension of the points some hold
    (``let p = (0.3, 0.1)``: 2; None when it is not a point or not known before the run)."""

    def __init__(self, names=(), task: str | None = None) -> None:
        super().__init__(names)
        self.dims: dict[str, int | None] = {}
        self.task = task  # the task whose body this is (its parameters are the names given)
        self.params = set(names)

    def let(self, name: str, dim: int | None) -> None:
        if name in self.dims and self.dims[name] != dim:
            dim = None  # different sizes at different places: only the run knows
        self.add(name)
        self.dims[name] = dim


class _Checker(A.Visitor):
    def __init__(self, program: A.Program, templates=None, settings: dict[str, str] | None = None,
                 backend: str | None = None) -> None:
        self.p = program
        self.warnings: list[Diagnostic] = []
        self.loader = loader_of(templates)
        self.settings, self.backend = settings, backend

    def error(self, message: str, pos: A.Pos, hint: str | None = None) -> CheckError:
        line = pos.line or None
        exc = CheckError(
            message, file=self.p.file, line=line, column=pos.column or None,
            source_line=source_line(self.p.source, line) if line else None, hint=hint,
        )
        exc.span = pos  # the whole node, for tools that underline it (the language server)
        return exc

    # ------------------------------------------------------------------ top level
    def run(self) -> CheckedProgram:
        p = self.p
        worlds = p.of(A.WorldDecl)
        if len(worlds) > 1:
            raise self.error("the world is declared twice", worlds[1].pos)
        world = worlds[0].name if worlds else registry.DEFAULT_WORLD
        known = registry.names("world")
        if worlds and world not in known:
            raise self.error(f"unknown world '{world}'", worlds[0].pos,
                             did_you_mean(world, known) or f"known worlds: {', '.join(known)}")
        self.world = WorldCheck(world, self.error, self.settings, self.backend)
        self.templates, self.files = {}, {}
        for imp in p.of(A.ImportDecl):
            if imp.alias in self.templates:
                raise self.error(f"'{imp.alias}' is imported twice", imp.pos, "use 'import ... as OTHER'")
            self.files[imp.alias], self.templates[imp.alias] = self.load(imp)
        self.points = {}
        self.point_dims: dict[str, int | None] = {}
        self.point_depths: dict[str, int] = {}
        for pt in p.of(A.PointDecl):
            if pt.name in self.points:
                raise self.error(f"point '{pt.name}' is declared twice", pt.pos)
            self.expr(pt.value, set(), pt.pos)
            self.point_depth(pt)
            self.points[pt.name] = pt.value
            self.point_dims[pt.name] = self.dim(pt.value, _Defined())
        hands = p.of(A.HandDecl)
        if len(hands) > 1:
            raise self.error("'hand at' is given twice", hands[1].pos)
        if hands:
            self.expr(hands[0].value, set(), hands[0].pos)
        self.tasks = {}
        for t in p.of(A.TaskDef):
            if t.name in self.tasks:
                raise self.error(f"task '{t.name}' is defined twice (first at line {self.tasks[t.name].pos.line})", t.pos)
            if t.name in RESERVED:
                raise self.error(f"'{t.name}' is reserved; name the task something else", t.pos)
            seen = set()
            for name, pos in zip(t.params, t.param_pos):
                if name in seen:
                    raise self.error(f"parameter '{name}' appears twice", pos)
                if name in RESERVED:
                    raise self.error(f"'{name}' is reserved and cannot be a parameter", pos)
                seen.add(name)
            self.tasks[t.name] = t
        mains = p.of(A.MainDef)
        if not mains:
            lines = p.source.splitlines() or [""]
            raise CheckError("the program has no entry point", file=p.file, line=max(len(lines), 1),
                             column=1, source_line=lines[-1] if lines else "",
                             hint="add 'main { ... }' with the statements to run")
        if len(mains) > 1:
            raise self.error(f"'main' is defined twice (first at line {mains[0].pos.line})", mains[1].pos)
        self.param_uses: dict[tuple[str, str], list] = {}
        self.call_dims: list = []
        for t in self.tasks.values():
            self.body(t.body, _Defined(t.params, t.name))
        self.body(mains[0].body, _Defined())
        self.arguments()
        self.recursion(mains[0])
        return CheckedProgram(p, world, self.templates, self.files, self.tasks, mains[0], self.points,
                              hands[0].value if hands else None, self.warnings, self.world.run_settings)

    def load(self, imp: A.ImportDecl):
        found = self.loader.find(imp.source, imp.is_path, self.p.file)
        if found is None:
            candidates = self.loader.candidates(imp.source, imp.is_path, self.p.file)
            known = self.loader.known(self.p.file)
            hint = did_you_mean(imp.source, known) if not imp.is_path else None
            where = str(candidates[0]) if imp.is_path else ", ".join(str(c.parent) for c in candidates)
            raise self.error(f"template '{imp.source}' not found (looked in {where})", imp.pos,
                             hint or (f"templates found: {', '.join(known)}" if known else
                                      "add the folder that holds it to HILA_PATH"))
        try:
            return found, self.loader.load(found)
        except HilaError as exc:
            raise self.error(f"cannot load template '{imp.source}': {exc.message}", imp.pos,
                             f"in {exc.location() or found}") from None

    # ------------------------------------------------------------------ statements
    def body(self, stmts, defined: set[str]) -> None:
        for s in stmts:
            self.visit(s, defined)

    def generic_visit(self, s, defined):
        """A statement with no rule of its own here: the names in its expressions, then the
        statements in its blocks, in source order."""
        for child in A.children(s):
            if isinstance(child, A.STATEMENTS):
                self.visit(child, defined)
            else:
                self.expr(child, defined, s.pos)

    def visit_RunStmt(self, s: A.RunStmt, defined: set[str]) -> None:
        self.run_stmt(s, defined)

    def visit_CallStmt(self, s: A.CallStmt, defined: set[str]) -> None:
        task = self.tasks.get(s.task)
        if task is None:
            hint = did_you_mean(s.task, self.tasks)
            if hint is None and s.task in self.templates:
                hint = f"to run a template write 'run {s.task}.TAG(...)'"
            raise self.error(f"unknown task '{s.task}'", s.pos, hint)
        if len(s.args) != len(task.params):
            raise self.error(
                f"task '{s.task}' takes {len(task.params)} argument(s) ({', '.join(task.params) or 'none'}), "
                f"got {len(s.args)}", s.pos, f"defined at line {task.pos.line}")
        self.expr(s.args, defined, s.pos)
        self.constraints(s.constraints, defined)
        self.call_dims.append((s, [self.dim(a, defined) for a in s.args]))

    def arguments(self) -> None:
        """A point passed to a task parameter that the task binds to an ICP has the ICP's size."""
        for call, dims in self.call_dims:
            task = self.tasks[call.task]
            for param, dim, arg in zip(task.params, dims, call.args):
                for ref, template_dim, icp in self.param_uses.get((call.task, param), []) if dim else ():
                    self.world.binding(ref, template_dim, icp, dim, arg.pos if arg.pos.line else call.pos,
                                       f" (through parameter '{param}' of task '{call.task}')")
                    self.world.reach(ref, icp, arg, self.points, (), arg.pos if arg.pos.line else call.pos,
                                     f" (through parameter '{param}' of task '{call.task}')")

    def visit_LetStmt(self, s: A.LetStmt, defined: set[str]) -> None:
        if s.name in RESERVED:
            raise self.error(f"'{s.name}' is reserved; pick another name", s.pos)
        self.expr(s.value, defined, s.pos)
        defined.let(s.name, self.dim(s.value, defined))

    def visit_WaitStmt(self, s: A.WaitStmt, defined: set[str]) -> None:
        self.world.event(s.wait.event, s.wait.pos if s.wait.pos.line else s.pos, len(s.wait.args))
        self.expr(s.wait.args, defined, s.pos)

    def visit_IfStmt(self, s: A.IfStmt, defined: set[str]) -> None:
        for cond, body in s.branches:
            self.expr(cond, defined, s.pos)
            self.body(body, defined)
        if s.orelse is not None:
            self.body(s.orelse, defined)

    def visit_WhileStmt(self, s, defined: set[str]) -> None:
        self.expr(s.cond, defined, s.pos)
        self.body(s.body, defined)

    visit_UntilStmt = visit_WhileStmt

    def visit_RepeatStmt(self, s: A.RepeatStmt, defined: set[str]) -> None:
        self.expr(s.count, defined, s.pos)
        if isinstance(s.count, A.Number) and (s.count.value < 0 or not float(s.count.value).is_integer()):
            raise self.error(f"repeat needs a whole number of times, got {A.expr_text(s.count)}", s.count.pos)
        if isinstance(s.count, A.Number) and s.count.value == 0:
            raise self.error("'repeat 0' never runs its block", s.pos, "remove it, or repeat at least once")
        self.body(s.body, defined)

    def template_icps(self, s: A.RunStmt) -> list[str]:
        """ICP names of the (sub-)template ``s`` runs (raises for unknown template or tag)."""
        template = self.templates.get(s.template)
        if template is None:
            hint = did_you_mean(s.template, self.templates)
            if hint is None and s.tag is None and s.template in self.tasks:
                hint = f"'{s.template}' is a task: call it as {s.template}(...)"
            if hint is None:
                hint = f"import it first: 'import {s.template}'" if not self.templates else \
                    f"imported templates: {', '.join(self.templates)}"
            raise self.error(f"unknown template '{s.template}'", s.ref_pos, hint)
        if s.tag is None:
            return list(template.icps)
        tags = template.tags()
        if s.tag not in tags:
            hint = did_you_mean(s.tag, tags) or (
                f"its tags are: {', '.join(tags)}" if tags else "it has no sub-templates; run it whole: "
                f"'run {s.template}(...)'")
            at = A.Pos(s.ref_pos.line, s.ref_pos.column + len(s.template) + 1, s.ref_pos.end_line,
                       s.ref_pos.end_column)
            raise self.error(f"template '{s.template}' has no sub-template '{s.tag}'", at, hint)
        return [k for k in template.icps if k not in (START, END)] + [START, END]

    def run_stmt(self, s: A.RunStmt, defined: set[str]) -> None:
        icps = self.template_icps(s)
        template = self.templates[s.template]
        dim = template.dim
        self.world.template(s.ref, dim, s.ref_pos)
        sub = template if s.tag is None else template.sub(s.tag)
        if s.pen != "up" and (s.pen == "down" or any(seg.contact for seg in (
                [template.segment(s.tag)] if s.tag is not None else template.segments))):
            self.world.drawn(s.ref, sub, s.ref_pos)
        covered: dict[str, A.Binding] = {}
        spread = [b for b in s.bindings if b.icp == A.SPREAD]
        if len(spread) > 1:
            raise self.error("only one '.*' spread per run", spread[1].pos)
        for b in s.bindings:
            if b.icp == A.SPREAD:
                self.expr(b.value, defined, b.pos)
                continue
            members = [b.icp] if b.icp in icps else [k for k in icps if k.startswith(b.icp + ".")]
            if not members:
                groups = {k.rsplit(".", 1)[0] for k in icps if "." in k}
                raise self.error(f"'{s.ref}' has no ICP '{b.icp}'", b.pos,
                                 did_you_mean(b.icp, list(icps) + list(groups)) or f"its ICPs: {', '.join(icps)}")
            for m in members:
                if m in covered:
                    raise self.error(f"ICP '{m}' is bound twice", b.pos, f"first bound at column {covered[m].pos.column}")
                covered[m] = b
            self.expr(b.value, defined, b.pos)
            if b.icp in icps:  # one ICP bound to one point (not a group bound to a group)
                self.remote_icp(s, b)
                self.world.binding(s.ref, dim, b.icp, self.dim(b.value, defined), b.pos)
                self.world.reach(s.ref, b.icp, b.value, self.points, defined, b.pos)
                value = b.value
                if (isinstance(value, A.Name) and len(value.parts) == 1 and value.parts[0] in defined.params
                        and value.parts[0] not in defined.dims):  # a parameter: checked at each call
                    self.param_uses.setdefault((defined.task, value.parts[0]), []).append((s.ref, dim, b.icp))
        self.constraints(s.constraints, defined)
        if s.track is not None:
            self.track(s, defined)
        unbound = [k for k in icps if k not in covered and k not in (START, END) and not spread]
        if unbound:
            raise self.error(
                f"unbound ICP{'s' if len(unbound) > 1 else ''} {', '.join(repr(u) for u in unbound)} of '{s.ref}'",
                s.pos, f"bind {'them' if len(unbound) > 1 else 'it'}, e.g. {unbound[0]} = POINT, "
                f"or leave {'them' if len(unbound) > 1 else 'it'} out on purpose with {unbound[0]} = none")
        self.free_end(s, sub, covered, bool(spread))

    def free_end(self, s: A.RunStmt, sub, covered: dict, spread: bool) -> None:
        """A note (``template-geometry``, severity ``note``: the program may mean it, as the shipped
        game.hila's retract does) when a pen-up run leaves its end free: no bound ICP
        places the last waypoints (:func:`hila_lang.hierarchy.step.free_tail`), so where it ends
        follows the demonstration, wherever the bound points are; the engine pulls that part into
        the arm's reach when it leaves it (:meth:`hila_lang.engine.run.RunExecutor.move`)."""
        # lazy: loads numpy, which importing this module does not
        import numpy as np

        from ..hierarchy.step import free_tail
        from ..osila.pairs import Pairs

        if s.pen == "down" or any(seg.contact for seg in sub.segments):
            return
        free = {k for k, b in covered.items() if isinstance(b.value, A.NoneLit)}
        bound = [k for k in sub.icps if k not in free and (k in covered or (k == START) or
                                                         (spread and k != END and "." not in k))]
        src = np.array([sub.icps[k] for k in bound], dtype=float).reshape(len(bound), sub.dim)
        tail = free_tail(sub, Pairs(tuple(bound), src, src))  # None when nothing is bound
        if tail is None:
            return
        path = np.asarray(sub.path, float)
        gap = np.linalg.norm(src - path[-1], axis=1)
        nearest = bound[int(np.argmin(gap))]
        said = ", ".join(f"{k} = none" for k in sorted(free)) or "nothing bound there"
        self.warnings.append(Diagnostic(
            "template-geometry",
            f"the end of '{s.ref}' is free ({said}; 'end' not bound): waypoints {tail + 1}-{len(path)} of "
            f"{len(path)} go where the demonstration went, ending {gap.min():.3f} {sub.units} from the nearest "
            f"bound ICP ('{nearest}'), wherever the bound points are; where that leaves the arm's reach a run made in "
            f"one move (no track, a still scene) pulls them in and says so in the trace; bind 'end' to say where it ends", self.p.file, s.pos, "note"))

    def remote_icp(self, s: A.RunStmt, b: A.Binding) -> None:
        """A warning (``template-geometry``) when ``b`` binds an ICP that the (sub-)template's path
        never comes near -- farther from it than :data:`REMOTE_ICP` of the path's extent: the
        point bound bends the whole path towards it, so where the path goes depends on where the
        demonstration went.  (The shipped circle's retract comes within 0.18 of its extent of
        ``hand``; a person's drawn retract that heads elsewhere, 0.58-2.1, and bound to the
        park it ran below the paper in 3 of 60 dry games.)"""
        # lazy: loads numpy, which importing this module does not
        import numpy as np

        if b.icp in (START, END) or isinstance(b.value, A.NoneLit):
            return
        template = self.templates[s.template]
        sub = template if s.tag is None else template.sub(s.tag)
        path, point = np.asarray(sub.path, float), np.asarray(sub.icps[b.icp], float)
        extent = float(np.linalg.norm(path - path[0], axis=1).max())
        near = float(np.linalg.norm(path - point, axis=1).min())
        if extent > 0 and near > REMOTE_ICP * extent:
            what = f"'{s.template}.{s.tag}'" if s.tag else f"'{s.template}'"
            self.warnings.append(Diagnostic(
                "template-geometry",
                f"ICP '{b.icp}' of {what} is bound here, but its path never comes near '{b.icp}' in the "
                f"template ({near:.3f} from it at the closest, the path spans {extent:.3f} {template.units}): the "
                f"point bound bends the whole path towards it, so where the path goes depends on where the "
                f"demonstration went (it may run through the table); bind it to none to keep the path as "
                f"demonstrated, placed by the other ICPs, or bind 'end' to say where it ends",
                self.p.file, b.pos))

    def track(self, s: A.RunStmt, defined: set[str]) -> None:
        """A run's ``track`` clause (see the module docstring)."""
        track = s.track
        self.world.track(track.pos)
        for name in track.names:
            self.expr(name, defined, track.pos)
            if not any(_tracks(b.value, name) for b in s.bindings):
                bound = sorted({A.source_text(n) for b in s.bindings for n in _names_in(b.value)})
                raise self.error(f"'track {A.source_text(name)}': no ICP of '{s.ref}' is bound through "
                                 f"'{A.source_text(name)}'", name.pos if name.pos.line else track.pos,
                                 f"track what the run binds ({', '.join(bound)})" if bound else
                                 "track a point group or point the run binds its ICPs to")
        seen: dict[str, A.TrackOption] = {}
        for o in track.options:
            if o.kind in seen:
                raise self.error(f"'{o.kind}' is given twice in one 'track'", o.pos,
                                 f"first given at column {seen[o.kind].pos.column}")
            seen[o.kind] = o
            low, high, closed = TRACK_RANGES[o.kind]
            if o.value > high or o.value < low or (o.value == low and not closed):
                unit = o.UNITS[o.kind]
                raise self.error(f"'{o.text()}': expected {'at least' if closed else 'more than'} {low:g} {unit} and "
                                 f"at most {high:g} {unit}", o.pos)
        lift, threshold = seen.get("lift"), seen.get("threshold")
        limit = threshold.value if threshold is not None else TRACK_THRESHOLD * 1000
        if lift is not None and lift.value < limit:
            raise self.error(f"'{lift.text()}' is below the threshold of {limit:g} mm: a move that small is not "
                             "followed at all, so the pen would never lift for it", lift.pos,
                             "lift above a larger move, or lower the threshold ('threshold N mm')")

    def constraints(self, constraints, defined: set[str]) -> None:
        """``via P`` takes no radius, ``avoid P`` needs one (a number of metres > 0 when written
        as a literal); P is a point of the world (x, y, z) or a point group, so a number, a string,
        a truth value, ``none`` or a point of another size is refused."""
        for c in constraints:
            if c.kind == "via" and c.radius is not None:
                raise self.error("a 'via' waypoint takes no radius", c.radius.pos if c.radius.pos.line else c.pos,
                                 "the route passes within OSILA's threshold of it; to keep away from a "
                                 "point write 'avoid POINT radius R'")
            if c.kind == "avoid" and c.radius is None:
                raise self.error("'avoid' needs a radius: avoid POINT radius R (metres)", c.pos)
            if isinstance(c.value, (A.Number, A.String, A.Bool, A.NoneLit)):
                raise self.error(f"'{c.kind}' needs a point or a point group, got {A.expr_text(c.value)}",
                                 c.value.pos if c.value.pos.line else c.pos,
                                 "e.g. (0.3, -0.1, 0.6), a point's name, or a group such as board.cell5")
            self.expr(c.value, defined, c.pos)
            if c.kind == "via":
                self.world.reach_via(c.value, self.points, defined, c.value.pos if c.value.pos.line else c.pos)
            size = self.dim(c.value, defined)
            if size is not None and size != 3:
                raise self.error(f"'{c.kind}' needs a point of the world (x, y, z), got the {size}-D point "
                                 f"{A.expr_text(c.value)}", c.value.pos if c.value.pos.line else c.pos,
                                 "give it 3 coordinates, metres (a 2-D template's constraints are projected "
                                 "onto its drawing surface, like its ICPs)")
            if c.radius is not None:
                self.expr(c.radius, defined, c.pos)
                if isinstance(c.radius, (A.String, A.Bool, A.NoneLit, A.Vector)):
                    raise self.error(f"an obstacle's radius must be a number of metres, got {A.expr_text(c.radius)}",
                                     c.radius.pos if c.radius.pos.line else c.pos)
                if isinstance(c.radius, A.Number) and c.radius.value <= 0:
                    raise self.error(f"an obstacle's radius must be more than 0 metres, got {A.expr_text(c.radius)}",
                                     c.radius.pos if c.radius.pos.line else c.pos)

    # ------------------------------------------------------------------ expressions
    def dim(self, e, defined) -> int | None:
        """How many coordinates the point ``e`` has, when that is known before the run (a
        literal, a program point, a world point, ``hand``, a ``let`` of one); None otherwise."""
        if isinstance(e, A.Vector):
            return len(e.items)
        if isinstance(e, A.Ask):
            return self.world.value_dim("question", e.name)
        if isinstance(e, A.Wait):
            return self.world.value_dim("event", e.event)
        if isinstance(e, A.Unary) and e.op == "-":
            return self.dim(e.operand, defined)
        if isinstance(e, A.Binary) and e.op in ("+", "-", "*", "/"):
            a, b = self.dim(e.left, defined), self.dim(e.right, defined)
            return a if b is None or a == b else (b if a is None else None)
        if not isinstance(e, A.Name):
            return None
        first = e.parts[0]
        if first in defined:
            return defined.dims.get(first) if len(e.parts) == 1 else None
        if e.text == "hand":
            return 3
        if e.text in self.point_dims:
            return self.point_dims[e.text]
        if first == "hand" or e.parts[-1] in ("x", "y", "z") or any(p.startswith(e.text + ".") for p in self.points):
            return None  # a coordinate, or a group of points
        return 3 if len(e.parts) > 1 else None  # a world point: (x, y, z) by the World protocol

    def point_depth(self, pt: A.PointDecl) -> None:
        """A ``point`` defined through other points nests as deep as they do, all of it added up
        when the run evaluates it: keep that within the nesting limit (no recursion here)."""
        # lazy: loads lark, which importing this module does not
        from .transformer import deepest

        found = deepest([pt.value])
        depth = 1 + (found[2] if found else 0)
        for n in _names_in(pt.value):
            depth = max(depth, 1 + self.point_depths.get(n.text, 0) + 1)
        self.point_depths[pt.name] = depth
        if depth > MAX_NESTING:
            raise self.error(f"point '{pt.name}' is defined through points defined through points ... "
                             f"{depth} levels deep (at most {MAX_NESTING})", pt.pos,
                             "define it by its coordinates, or through fewer other points")

    def expr(self, e, defined: set[str], where: A.Pos) -> None:
        """Check the names in expression ``e`` (or a tuple of them); ``where`` locates a name
        that has no position of its own."""
        for x in (e if isinstance(e, tuple) else (e,)):
            _Names(self, defined, where).visit(x)

    def recursion(self, main: A.MainDef) -> None:
        """No task calls itself, the inlined program stays within bounds (:mod:`.calls`), and a
        warning for each task main never calls."""
        for name in check_calls(self.tasks, main, self.error):
            t = self.tasks[name]
            self.warnings.append(Diagnostic(
                "unused-task", f"task '{name}' is never called", self.p.file,
                A.Pos(t.pos.line, t.pos.column, t.pos.line, t.pos.column + len("task"))))


def _tracks(value, tracked: A.Name) -> bool:
    """Whether the binding ``value`` goes through the tracked name (``c`` tracks ``c``, ``c.tl``)."""
    n = len(tracked.parts)
    return any(name.parts[:n] == tracked.parts for name in _names_in(value))


def _names_in(e) -> list:
    """Every :class:`~hila_lang.language.ast.Name` in expression ``e`` (without recursion)."""
    out, stack = [], [e]
    while stack:
        node = stack.pop()
        if isinstance(node, A.Name):
            out.append(node)
        stack.extend(A.children(node))
    return out


class _Names(A.Visitor):
    """Every plain name in an expression is known, and every question, event and world point
    the world declares; points have 2 or 3 coordinates."""

    def __init__(self, checker: "_Checker", defined: set[str], where: A.Pos) -> None:
        self.c, self.defined, self.where = checker, defined, where

    def _pos(self, e) -> A.Pos:
        return e.pos if e.pos.line else self.where

    def visit_Ask(self, e: A.Ask) -> None:
        self.c.world.question(e.name, self._pos(e), len(e.args))
        self.generic_visit(e)

    def visit_Wait(self, e: A.Wait) -> None:
        self.c.world.event(e.event, self._pos(e), len(e.args))
        self.generic_visit(e)

    def visit_Name(self, e: A.Name) -> None:
        c, first = self.c, e.parts[0]
        if len(e.parts) > 1 and first not in self.defined and first != "hand":
            head, _, attr = e.text.rpartition(".")
            program_point = (e.text in c.points or any(p.startswith(e.text + ".") for p in c.points)
                             or (attr in ("x", "y", "z") and head in c.points))
            if not program_point:
                c.world.point(e.text, self._pos(e))
            return
        if first in self.defined or first == "hand" or len(e.parts) > 1:
            return
        if first in c.points or any(p.startswith(first + ".") for p in c.points):
            return
        choices = set(self.defined) | set(c.points) | {"hand"}
        raise c.error(f"unknown name '{first}'", e.pos if e.pos.line else self.where,
                      did_you_mean(first, choices) or
                      "define it with 'let' or 'point', or write a world point by its full dotted name")

    def visit_Vector(self, e: A.Vector) -> None:
        if len(e.items) not in (2, 3):
            raise self.c.error(f"a point has 2 or 3 coordinates, got {len(e.items)}", e.pos)
        self.generic_visit(e)


def check(program: A.Program, templates=None, *, settings: dict[str, str] | None = None,
          backend: str | None = None) -> CheckedProgram:
    """Check ``program``; raise :class:`CheckError` at the first mistake (its ``span``: the
    offending node's :class:`~hila_lang.language.ast.Pos`); warnings are :class:`Diagnostic`.

    ``templates``: the :class:`~hila_lang.language.loader.TemplateLoader` that finds and reads
    imported templates (the :class:`~hila_lang.language.environment.Environment`'s, with its
    cache; None: a new one on the default search path).
    ``settings`` (the ``--set`` pairs as typed) and ``backend`` are what the program will run
    with: they are parsed here (a bad one is an InputError naming it) and the world's questions,
    events and points are those it declares with them (:mod:`.worldcheck`).  Without settings
    (None) a world whose names follow from its settings is not checked by name.
    """
    return _Checker(program, templates, settings, backend).run()


def resolve_import(program: A.Program, imp: A.ImportDecl, templates=None):
    """``(path, Template)`` of one import of ``program``, found as :func:`check` finds it
    (CheckError when it is not found or does not load)."""
    return _Checker(program, templates).load(imp)
