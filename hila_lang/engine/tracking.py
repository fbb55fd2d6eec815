"""A run whose ICPs stay live while it runs (the ``track`` clause): look, warp the rest again, blend it in.

``run circle.draw(c.*, hand = none) track c every 100 ms blend 5 mm lift above 5 mm``: the run
state's executor (:mod:`.run`) warps the step as always, then hands it to :func:`follow`
instead of one blocking ``backend.move``.  The back end's ``streaming`` capability
(:class:`hila_lang.plugins.protocols.Streaming`) begins the path; every ``every`` seconds of its
clock:

1. the world's ``tracking`` capability (:class:`hila_lang.plugins.protocols.Tracking`) lets the
   robot perceive the scene again (``look``: its own eyes where the world uses them, never the
   simulator's truth), and the run's bindings are evaluated again through the world, as they
   were when the step began;
2. the ICPs bound through a tracked name (:func:`tracked_icps`) are compared with the points the
   current plan was warped onto; when one moved more than ``threshold``, the step is warped again
   by the same HILA step (:func:`hila_lang.hierarchy.step.hila_step`: OSILA on the same
   sub-template and the same ICPs, the tracked ones where they are now).  The tracked points are
   taken to move as one object (a sheet, a board, a map): the similarity that takes their places
   in the plan to their perceived ones (:func:`motion`, least squares) places them all, so one
   point seen a little off does not bend the warp and one not seen moves with the rest (a
   deformation of the object itself is not followed; two objects that move apart are two
   tracked runs).  The points a look gives are where the scene *was* (a look is ``latency`` old,
   and its plan is drawn until the next look): :class:`Prediction` carries moving points over
   that time along their motion estimated from the last looks, averages still ones, and takes a
   knock as seen.  The step's ``start`` (where the hand was when it began: the first ink of a
   stroke) moves with them, so the shape is re-warped whole in the moved scene and not pulled
   back to where the sheet was;
3. the rest of the new plan, from the template point the arm has not reached yet, replaces the
   stream's tail, blended in from the pen's *measured* position (the robot's own joints) over
   ``blend`` metres of path with a minimum-jerk weight (:func:`blend_in`);
4. when the points jumped by more than ``lift above`` while the pen is down, the pen lifts
   (:data:`LIFT_HEIGHT`), travels, and is put down where its ink stopped -- the pen's position
   at the look before, carried along by the same similarity -- and the new plan is blended in
   from there (a jump under a pen that is down cannot be undone; lifting and resuming can).

Each re-plan is a :class:`Replan` (time, how far the points moved, where the new plan takes over,
the blend, the new tail): a line of the run's trace text, recorded (``--record``), shown by
``hila replay`` and compared by ``--verify``.  With still points nothing is re-planned and the
path is the untracked step's.

A world whose scene moves during steps (``tracking.moving``: ``board.slide``) gets its clock on
every step of a streaming back end, tracked or not: an untracked step is streamed without
looking (the control without re-planning).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import HilaRuntimeError
from ..hierarchy.step import hila_step
from ..language import ast as A
from ..osila.fallback import fit_similarity
from ..osila.motion import minimum_jerk
from ..osila.robust import MIN_PAIRS, screen
from .trace import fmt_point

START = "start"
#: how high a lifted pen goes above where it was, metres (the pen inks within 0.5 mm of the paper)
LIFT_HEIGHT = 0.01
#: the blend is sampled at most this far apart, metres, so the arm follows its curve and not a chord
BLEND_SPACING = 0.0005
#: a look counts when it sees at least this share of the tracked points the plan has: the move of
#: the rest is told from those seen (in the picture world, with the arm in view, some looks found 1-3
#: of 15 features, and the similarity of 1-3 points, a few mm off each, turned the route by 11 cm)
MIN_SEEN = 0.5
#: the looks whose perceived points the motion is estimated from: those of the last this many
#: seconds (at least 3 looks; see :class:`Prediction`, and docs/language.md for the measurement);
#: 0: no prediction, each look taken as it is
PREDICT_WINDOW = 0.3
#: the looks' scatter is told from at least this many windows (one window of 3-4 looks leaves 1-2
#: degrees of freedom: its scatter alone was a third of the true one in the bench's first looks)
PREDICT_WINDOWS = 3
#: the estimated speed must exceed this many of its standard errors to be used
PREDICT_Z = 2.0


@dataclass
class Replan:
    """One re-plan of a tracked run (see the module docstring).

    Attributes
    ----------
    t : float
        Seconds since the step began moving (the back end's clock).
    stamp : int
        The template point the new plan takes over from.
    index : int
        The waypoint of the followed path its tail replaced from.
    moved : float
        The largest move of a tracked ICP since the plan before, metres.
    which : str
        The ICP that moved most.
    blend : float
        Metres of path the new plan was blended in over.
    lifted : bool
        The pen was lifted and put down where its ink stopped.
    points : dict
        The tracked ICPs where the re-plan put them (the similarity of their perceived moves):
        name -> (3,).
    tail : ndarray, shape (N, 3)
        What replaced the path from ``index`` on.
    """

    t: float
    stamp: int
    index: int
    moved: float
    which: str
    blend: float
    lifted: bool
    points: dict = field(default_factory=dict)
    tail: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    of: int = 0  # the template's points
    ahead: float = 0.0  # seconds the looked-at points were carried ahead along their motion (:class:`Prediction`)

    def text(self) -> str:
        lift = "; the pen lifted, carried and put down where its ink stopped" if self.lifted else ""
        if self.ahead > 0:
            lift = f"; the moving points carried {self.ahead * 1000:g} ms ahead" + lift
        return (f"re-plan at {self.t:.3f} s: {self.which} moved {self.moved * 1000:.1f} mm; warped again from point "
                f"{self.stamp} of {self.of}, blended over {self.blend * 1000:g} mm{lift}; {len(self.tail)} new points "
                f"from {fmt_point(self.tail[0])}")

    def to_dict(self) -> dict:
        return {"t": self.t, "stamp": self.stamp, "index": self.index, "moved": self.moved, "which": self.which,
                "blend": self.blend, "lifted": self.lifted, "of": self.of, "ahead": self.ahead,
                "points": {k: np.asarray(v, dtype=float).tolist() for k, v in self.points.items()},
                "tail": np.asarray(self.tail, dtype=float).tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> "Replan":
        return cls(float(d["t"]), int(d["stamp"]), int(d["index"]), float(d["moved"]), str(d["which"]),
                   float(d["blend"]), bool(d["lifted"]), {k: np.asarray(v, dtype=float) for k, v in d["points"].items()},
                   np.asarray(d["tail"], dtype=float).reshape(-1, 3), int(d.get("of", 0)), float(d.get("ahead", 0.0)))


@dataclass
class Followed:
    """What a streamed run did: the path as it ended (the first plan with its replaced tails), the
    executed pen-tip trace, and the re-plans."""

    path: np.ndarray
    executed: np.ndarray
    replans: list[Replan]


def _mentions(expr, tracked) -> bool:
    """Whether expression ``expr`` goes through one of the ``tracked`` names (a variable by its
    slot, a world name by its dotted prefix)."""
    stack = [expr]
    while stack:
        e = stack.pop()
        for t in tracked:
            if isinstance(e, A.Var) and isinstance(t, A.Var) and e.slot == t.slot and e.attrs[:len(t.attrs)] == t.attrs:
                return True
            if isinstance(e, A.Name) and isinstance(t, A.Name) and e.parts[:len(t.parts)] == t.parts:
                return True
        stack.extend(A.children(e))
    return False


def tracked_icps(st, template) -> list[str]:
    """The ICPs of ``template`` that run state ``st`` binds through a tracked name, template order."""
    tracked = st.track.names
    by_icp: dict[str, object] = {}
    spread = None
    for icp, expr in st.bindings:
        if icp == A.SPREAD:
            spread = expr
            continue
        for k in template.icps:
            if k == icp or k.startswith(icp + "."):
                by_icp[k] = expr
    if spread is not None:
        for k in template.icps:
            if k not in by_icp and k not in (START, "end"):
                by_icp[k] = spread
    return [k for k in template.icps if k in by_icp and _mentions(by_icp[k], tracked)]


def motion(before: np.ndarray, after: np.ndarray):
    """The similarity (``x -> scale * R @ x + shift``) that takes points ``before`` (K, 3) to
    ``after`` (K, 3) in the least-squares sense, as a function of points (..., 3): one point gives
    a translation, collinear ones the minimal rotation (:func:`hila_lang.osila.fallback.fit_similarity`)."""
    before, after = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    if len(before) == 1:
        shift = after[0] - before[0]
        return lambda x: np.asarray(x, dtype=float) + shift
    rank = int(np.linalg.matrix_rank(before - before.mean(0), tol=1e-9))
    scale, R, shift = fit_similarity(before, after, max(rank, 1))
    return lambda x: scale * np.asarray(x, dtype=float) @ R.T + shift


def blend_in(start: np.ndarray, path: np.ndarray, stamps=None, length: float = 0.0):
    """``path`` (N, 3) pulled onto ``start`` (3,) at its beginning, letting go over ``length``
    metres of its arc with the minimum-jerk weight: point ``p`` at arc ``a`` becomes
    ``p + (1 - w(a / length)) * (start - path[0])``.  The blended part is sampled at most
    :data:`BLEND_SPACING` apart (its own vertices kept).  ``length`` 0: ``start``, then ``path``
    as it is.  Returns the points (M, 3) and each one's template point (M,), interpolated from
    ``stamps`` (N,), the template points of ``path`` (default 0, 1, ...)."""
    path = np.asarray(path, dtype=float)
    start = np.asarray(start, dtype=float)
    stamps = np.arange(len(path), dtype=float) if stamps is None else np.asarray(stamps, dtype=float)
    index = np.arange(len(path), dtype=float)
    if length <= 0 or len(path) == 1:
        return np.vstack([start, path]), np.concatenate([stamps[:1], stamps])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    inside = arc < length
    sampled = np.unique(np.concatenate([np.arange(0.0, min(length, arc[-1]), BLEND_SPACING), arc[inside]]))
    at = np.concatenate([np.interp(sampled, arc, index), index[~inside]])
    where = np.concatenate([sampled, arc[~inside]])
    lo = np.minimum(np.floor(at).astype(int), len(path) - 1)
    hi = np.minimum(lo + 1, len(path) - 1)
    points = path[lo] + (at - lo)[:, None] * (path[hi] - path[lo])
    points = points + (1.0 - minimum_jerk(where / length))[:, None] * (start - path[0])
    return points, stamps[lo] + (at - lo) * (stamps[hi] - stamps[lo])


def nearest_stamp(path: np.ndarray, point: np.ndarray, around: float, reach: float) -> float:
    """The (fractional) index of the point of ``path`` (T, 3) nearest to ``point`` (3,), looked for
    only within ``reach`` metres of arc of index ``around``: a closed shape passes its start again
    at its end, and the pen is near where it was, not on the far side."""
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    if len(path) == 1:
        return 0.0
    here = float(np.interp(around, np.arange(len(path)), arc))
    a, b = path[:-1], path[1:]
    ab = b - a
    u = np.clip(((point - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-18), 0.0, 1.0)
    d = np.linalg.norm(a + u[:, None] * ab - point, axis=1)
    near = (arc[1:] >= here - reach) & (arc[:-1] <= here + reach)
    d[~near] = np.inf
    i = int(np.argmin(d))
    return float(i + u[i])


def _from(path: np.ndarray, stamp: float) -> tuple[np.ndarray, np.ndarray]:
    """``path`` from fractional index ``stamp`` on (the point there, then the points after it),
    and their indices."""
    i = int(np.floor(stamp))
    if i >= len(path) - 1:
        return path[-1:], np.array([float(len(path) - 1)])
    first = path[i] + (stamp - i) * (path[i + 1] - path[i])
    return np.vstack([first, path[i + 1:]]), np.concatenate([[stamp], np.arange(i + 1, len(path), dtype=float)])


def _moved(plan: dict, now: dict, names) -> tuple[float, str]:
    """The largest move of the named ICPs between ``plan`` and ``now`` (metres) and the ICP."""
    best, which = 0.0, ""
    for k in names:
        if plan.get(k) is None or now.get(k) is None:
            continue
        d = float(np.linalg.norm(np.asarray(now[k], dtype=float) - np.asarray(plan[k], dtype=float)))
        if d > best:
            best, which = d, k
    return best, which


class Prediction:
    """Where the tracked points are while the new plan is drawn, from where the robot saw them.

    A look shows the points as they were ``latency`` seconds before (the world's senses' known
    delay, its ``tracking.latency``; 0 when it perceives at once), and the plan made from it is
    drawn until the next look, ``every`` seconds on: a sheet that keeps moving is, on average over
    that time, ``latency + every / 2`` further on than seen (the *horizon*).  Each look's points
    are placed by the similarity of their moves (one object), and kept with the time they were
    seen at.  The noise of the looks is in mind: a least-squares line through each point's places
    over the looks of the last :data:`PREDICT_WINDOW` seconds (at least 3) leaves residuals, and
    their variance, pooled over the step (the median over its windows, from
    :data:`PREDICT_WINDOWS` on: a window with a start, a stop or a knock in it fits badly and does
    not set it), is one look's scatter -- hence the standard error of a line's velocity.

    - **moving**: the window's speed exceeds :data:`PREDICT_Z` standard errors: the last look's
      points are carried over the horizon along the window's velocity (a constant velocity of each
      point: a turn followed to first order);
    - **still**: it does not.  The looks since the window first said so (one look taken as moving
      between still ones, a false alarm of the noise, does not end it) are one run; through them
      a line again: when its (longer, so more sensitive) speed exceeds ``PREDICT_Z`` standard
      errors the points drift slowly and are carried over the horizon along it from the line's
      place at the last look; otherwise they stand where the run's looks average (the noise
      averaged out rather than followed, and the prediction gone when the motion stops);
    - **knock**: a look farther from where the window's line put it than 2 * ``PREDICT_Z`` of its
      standard errors (or than the clause's ``lift above``): the looks before say nothing of what
      follows; they are forgotten and this look is taken as it is.

    Until the scatter is known (the first :data:`PREDICT_WINDOWS` windows) and for the first two
    looks after a knock, a look is taken as it is (as without prediction).  Points that do not
    move are never moved: their lines are flat and their average is where they are.

    Parameters
    ----------
    origin : ndarray, shape (K, 3)
        The tracked points the step's first plan was warped onto (the ones it has).
    latency, every : float
        Seconds: how old a look is, and between two looks.
    lift : float or None
        The clause's ``lift above`` (metres): a look this far off is a knock whatever the scatter.
    """

    def __init__(self, origin: np.ndarray, latency: float, every: float, lift: float | None = None) -> None:
        self.origin = np.asarray(origin, dtype=float)
        self.latency, self.every, self.lift = float(latency), float(every), lift
        self.horizon = self.latency + 0.5 * self.every
        self.looks: list[tuple[float, np.ndarray]] = []  # (when the points were as seen, the points (K, 3))
        self.scatters: list[float] = []  # each window's residual variance of one look, metres^2 per point
        self.fit: tuple | None = None  # the last window's line: (mean time, mean points, velocity, n, spread)
        self.still_since = 0.0  # when the run of still looks began (seen time)
        self.moving = 0  # looks in a row taken as moving
        self.carried = 0.0  # seconds the last look's points were carried ahead (0: not)
        self.state = "unknown"  # "moving", "still", "knock" or "unknown": what the last look was taken as

    def noise(self) -> float | None:
        """One look's scatter (metres^2 per point), or None before :data:`PREDICT_WINDOWS` windows."""
        return float(np.median(self.scatters)) if len(self.scatters) >= PREDICT_WINDOWS else None

    def line(self, since: float) -> tuple:
        """The least-squares line through the looks seen since ``since`` (at least the last 3):
        (mean time, mean points (K, 3), velocity (K, 3), looks, spread of their times, residual
        variance of one look per point)."""
        recent = [(t, p) for t, p in self.looks if t >= since - 1e-9]
        if len(recent) < 3:
            recent = self.looks[-3:]
        t = np.array([r[0] for r in recent])
        P = np.stack([r[1] for r in recent])  # (n, K, 3)
        tm, Pm = float(t.mean()), P.mean(0)
        dt = t - tm
        spread = float((dt ** 2).sum())
        v = np.einsum("n,nkd->kd", dt, P - Pm) / max(spread, 1e-18)
        residual = P - Pm - dt[:, None, None] * v
        scatter = float((residual ** 2).sum()) / (P.shape[1] * (len(t) - 2))
        return tm, Pm, v, len(t), spread, scatter

    def _knock(self, when: float, here: np.ndarray) -> bool:
        """Whether ``here`` (seen at ``when``) is off the last window's line by more than its noise."""
        noise = self.noise()
        if self.fit is None or noise is None:
            return False
        tm, Pm, v, n, spread = self.fit
        lag = when - tm
        off = float(((here - Pm - lag * v) ** 2).sum()) / len(here)
        return off > (2 * PREDICT_Z) ** 2 * noise * (1.0 + 1.0 / n + lag ** 2 / spread) or \
            (self.lift is not None and off > self.lift ** 2)

    def add(self, t: float, kept: np.ndarray, seen: np.ndarray) -> tuple[np.ndarray, str]:
        """Take a look at ``t`` seconds (the clock) that saw origin points ``kept`` (mask (K,)) at
        ``seen`` (M, 3): all K points where they are taken to be (see the class docstring), and
        what the look was taken as."""
        here = motion(self.origin[kept], seen)(self.origin)
        when = t - self.latency
        self.carried = 0.0
        knock = self._knock(when, here)
        if knock:
            self.looks, self.fit = [], None
        self.looks.append((when, here))
        if len(self.looks) < 3:
            self.fit, self.state = None, "knock" if knock or self.state == "knock" else "unknown"
            return here, self.state
        tm, Pm, v, n, spread, scatter = self.line(when - PREDICT_WINDOW)
        self.scatters.append(scatter)
        noise = self.noise()
        self.fit = (tm, Pm, v, n, spread)
        if noise is None:
            self.state = "unknown"
            return here, self.state
        if _significant(v, spread, noise):
            self.state, self.moving, self.carried = "moving", self.moving + 1, self.horizon
            return here + self.horizon * v, self.state
        if self.state not in ("still", "moving") or self.moving > 1:
            self.still_since = when - PREDICT_WINDOW
        self.state, self.moving = "still", 0
        tm, Pm, v, n, spread, _ = self.line(self.still_since)
        if _significant(v, spread, noise):
            self.carried = self.horizon
            return Pm + (when - tm + self.horizon) * v, self.state
        return Pm, self.state


def _significant(v: np.ndarray, spread: float, noise: float) -> bool:
    """Whether velocity ``v`` (K, 3) of a line through looks whose times spread ``spread`` (s^2)
    is more than :data:`PREDICT_Z` standard errors of it (one look's scatter ``noise``, m^2)."""
    speed2 = float((v ** 2).sum()) / len(v)
    return speed2 > 0.0 and speed2 > PREDICT_Z ** 2 * noise / spread


class _Follower:
    """The state of one streamed run (see :func:`follow`)."""

    def __init__(self, run, st, template, step, binding: dict) -> None:
        ctx = run.ctx
        self.run, self.st, self.template, self.step = run, st, template, step
        self.backend, self.spec, self.pen = ctx.backend, st.track, bool(st.pen_down)
        # a re-warp decides as the first plan did: the same threshold, the ICP pairs it kept (one
        # it rejected as an outlier stays out) and no screening again, so a point perceived a little
        # differently does not change which pairs the warp goes through
        result = step.result
        self.options = {**ctx.osila_options, "reject": "none", "threshold": float(result.threshold)}
        rejected = [] if result.pairs is None else [step.icps.names[int(i)] for i in result.pairs.rejected]
        self.binding = {k: None if k in rejected else v for k, v in binding.items()}  # what the plan was warped onto
        self.names = tracked_icps(st, template) if self.spec is not None else []
        self.plan = {k: binding.get(k) for k in self.names}
        #: the step's start (the hand where it began) moves with the tracked points
        self.start = step.icps[START] if START in step.icps and START not in binding else None
        self.current = np.asarray(step.path, dtype=float).copy()  # the followed path, as the stream holds it
        self.T = len(self.current)
        self.stamps = np.arange(self.T, dtype=float)  # each of its waypoints' template point
        self.replans: list[Replan] = []
        self.last = (np.asarray(ctx.backend.hand_position(), dtype=float), 0.0)  # pen down, and its point, at the look before
        self.air: tuple | None = None  # a lifted pen: (waypoint where it is put down, that point, its template point)
        world = getattr(ctx.world, "tracking", None)
        self.has = [n for n in self.names if self.plan.get(n) is not None]
        self.predict = None if not self.has or PREDICT_WINDOW <= 0 else Prediction(
            np.array([self.plan[n] for n in self.has]), float(getattr(world, "latency", 0.0) or 0.0),
            self.spec.every, self.spec.lift)
        self.ahead = 0.0  # how far ahead (seconds) the points of the last look were carried

    def look(self, world, progress) -> None:
        """One tick of a tracked run: look, compare, warp again if the tracked points moved."""
        spec = self.spec
        world.look()
        now = self.predicted(progress.t, self.seen(self.run.scene_binding(self.st)))
        here = np.asarray(self.backend.hand_position(), dtype=float)
        k = int(progress.index)
        stamp = float(self.stamps[k]) if k < len(self.stamps) else float(self.T)
        if self.air is not None and k > self.air[0]:
            self.air = None  # the pen is down again
        moved, which = _moved(self.plan, now, self.names)
        if moved > spec.threshold and stamp < self.T - 1:
            self.replan(progress, now, here, k, stamp, moved, which)
        if self.air is None:
            self.last = (here, stamp)

    def predicted(self, t: float, now: dict) -> dict:
        """The tracked points of a look at ``t`` (:meth:`seen`) carried to where they will be
        while the plan made from it is drawn (:class:`Prediction`); as seen when no motion is told."""
        self.ahead = 0.0
        if self.predict is None:
            return now
        kept = np.array([now.get(n) is not None for n in self.has])
        if not kept.any():
            return now
        placed, _ = self.predict.add(t, kept, np.array([now[n] for n, k in zip(self.has, kept) if k]))
        self.ahead = self.predict.carried
        return {**now, **dict(zip(self.has, placed))}

    def seen(self, binding: dict) -> dict:
        """The tracked ICPs in ``binding`` (the bindings evaluated at a look) that the robot follows:
        only those the plan has (one it did not see when the step began stays out), and, with
        :data:`~hila_lang.osila.robust.MIN_PAIRS` or more, only those whose move agrees with the
        others' (OSILA's own screening of pairs, :func:`hila_lang.osila.robust.screen`, on the
        pairs plan -> now: a feature matched to a look-alike elsewhere moves unlike the sheet)."""
        now = {n: binding.get(n) if self.plan.get(n) is not None else None for n in self.names}
        both = [n for n in self.names if now[n] is not None]
        if len(both) >= MIN_PAIRS:
            chosen = screen(np.array([self.plan[n] for n in both]), np.array([now[n] for n in both]))
            for i in chosen.rejected:
                now[both[int(i)]] = None
        planned = sum(v is not None for v in self.plan.values())
        if sum(v is not None for v in now.values()) < MIN_SEEN * planned:
            return dict.fromkeys(self.names)  # too little seen to say how the rest moved: this look does not count
        return now

    def replan(self, progress, now: dict, here: np.ndarray, k: int, stamp: float, moved: float, which: str) -> None:
        spec, names = self.spec, self.names
        kept = [n for n in names if self.plan.get(n) is not None and now.get(n) is not None]
        move = motion(np.array([self.plan[n] for n in kept]), np.array([now[n] for n in kept]))
        # the tracked points move as one object: each where the similarity of their perceived moves
        # puts it (one seen badly does not bend the warp; one not seen is carried along)
        now = {n: None if self.plan.get(n) is None else move(self.plan[n]) for n in names}
        task = dict(self.binding)
        task.update(now)
        self.start = None if self.start is None else move(self.start)
        new = hila_step(self.template, task, self.start, constraints=self.step.constraints,
                        surface=self.run.surface(), **self.options).path
        # the new plan goes on from its point nearest to where the pen is (or is put down) in the
        # moved scene: a scene that moved along the stroke left the pen behind (or ahead of) the
        # waypoint it was heading for
        reach = 2.0 * moved + spec.blend + float(np.linalg.norm(here - self.last[0]))
        under = float(np.linalg.norm(move(self.last[0]) - self.last[0]))  # how far the scene moved under the pen
        up = np.array([0.0, 0.0, LIFT_HEIGHT])
        knock = self.predict is None or self.predict.state != "moving"  # a motion followed is no knock
        lifted = self.air is not None or (self.pen and spec.lift is not None and under > spec.lift and knock)
        if lifted:  # carried over (up first, unless up already), put down where the ink stopped, moved along
            down, near = (move(self.air[1]), self.air[2]) if self.air is not None else (move(self.last[0]), self.last[1])
            at = nearest_stamp(new, down, near, reach)
            blended, tail_stamps = blend_in(down, *_from(new, at), spec.blend)
            rise = [] if self.air is not None else [here + up]
            tail = np.vstack(rise + [down + up, blended])
            tail_stamps = np.concatenate([[stamp] * len(rise), [at], tail_stamps])
            self.air = (k + len(rise) + 1, down, at)
        else:
            at = nearest_stamp(new, here, stamp, reach)
            tail, tail_stamps = blend_in(here, *_from(new, at), spec.blend)
        self.backend.streaming.replace(k, tail)
        self.current = np.vstack([self.current[:k], tail])
        self.stamps = np.concatenate([self.stamps[:k], tail_stamps])
        self.replans.append(Replan(progress.t, int(np.floor(at)), k, moved, which, spec.blend, bool(lifted),
                                   {n: np.asarray(now[n], dtype=float) for n in names if now.get(n) is not None},
                                   tail, self.T, self.ahead))
        self.binding = task
        self.plan = {n: now.get(n) for n in names}


def follow(run, st, template, step, binding: dict) -> Followed:
    """Stream run state ``st`` (its first plan ``step``, warped onto ``binding``) and keep its
    tracked ICPs live (see the module docstring).  ``run`` is the run state's executor."""
    ctx = run.ctx
    stream = ctx.backend.streaming
    world = getattr(ctx.world, "tracking", None)
    spec = st.track
    if spec is not None and (stream is None or world is None):
        missing = "the back end cannot change the path it follows" if stream is None else \
            "the world cannot show the robot its points while it moves"
        raise HilaRuntimeError(f"'track' cannot run here: {missing}", state=st.name)
    follower = _Follower(run, st, template, step, binding)
    seconds = stream.begin(follower.current, pen_down=follower.pen, label=st.name)
    tick = None if world is None else world.elapse
    if world is not None:
        world.begin(st.name, follower.pen, seconds)
    try:
        while True:
            progress = stream.advance(spec.every if spec is not None else seconds + 1.0, tick)
            if progress.done:
                break
            if spec is not None:
                follower.look(world, progress)
        executed = stream.finish(tick)
    except BaseException:
        stream.stop()
        raise
    finally:
        if world is not None:
            world.end()
    return Followed(follower.current, np.asarray(executed, dtype=float), follower.replans)


def streams(ctx, st) -> bool:
    """Whether run state ``st`` goes through :func:`follow`: it tracks, or the world's scene moves
    during steps and the back end can stream."""
    if st.track is not None:
        return True
    world = getattr(ctx.world, "tracking", None)
    return world is not None and bool(world.moving) and ctx.backend.streaming is not None
