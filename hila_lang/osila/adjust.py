"""Iterative plan adjustment: warp, route, check, add constraint pairs, repeat (docs/design.md §2.2).

First, ICPs whose template point lies on the template path and that carry the task's time (a
boundary of an equal-time split, a point at a time fraction: option ``task_times``) are re-timed
(:mod:`.timing`): which part of the template passes them is estimated again and the template
re-timed so each is still met at its own stamp.  Then each round fits the
warp on the ICP pairs plus the pairs added so far (checked for amplification
on the template path, :mod:`.tps`), maps the template, picks the minimum-energy route through the
candidate balls (candidates inside an obstacle are excluded up front), and checks the route:

- a *forced waypoint* is violated when no route point lies within ``threshold`` of it; the repair
  pair is (template point whose mapped point is nearest the forced point -> the forced point);
- a *pinned* stamp has one candidate only.  The first and the last stamp are always pinned: the
  route runs between the mapped start and the mapped goal (free ends would let the energy term
  shorten the movement at both ends, an undershoot of up to the threshold).  Stamps are pinned
  by the option ``pin``, and
  automatically where an ICP's template point is a waypoint of the template (a segment
  boundary, a sub-template's start or end): a bound ICP on the path is met exactly, not within
  the threshold.  Pinned to a given point, the pair (template point at that stamp -> the point)
  joins the warp as an exact pair, placed after every other pair so it wins a merge with an ICP
  at the same template point, and the waypoint IS the point (bit for bit).  Pinned without a
  point, the waypoint is its mapped point (the ICP's task point, if the stamp is an ICP);
- an *obstacle* (sphere) is violated when the route — its waypoints AND the straight segments
  between consecutive waypoints — comes closer than ``radius + margin`` to its centre.  For each
  run of consecutive violating segments the deepest one is repaired: if its nearest point to
  the centre is a waypoint, that waypoint's template point is paired with the point pushed
  radially out to ``radius + margin + clearance``; if the segment passes through between its
  waypoints, both waypoints are paired with themselves moved out in parallel, past the sphere by
  ``clearance``.  The clearance is the larger of the threshold (so the repaired waypoint's whole
  candidate ball is outside) and :data:`CLEARANCE` × the mapped path's size (so the warp, bent by
  the new pair, carries the neighbouring segments out too, even when the ball is tiny).

Between rounds the pairs only grow, so the warp's inverses are the last round's bordered with
the new pairs (:mod:`.bordered`), not taken afresh.  Where the first round bent the path (both
its ends were pairs: :mod:`.pathwarp`), a repair pair is one more pair on the path, met at its
stamp with the path's shape kept around it; otherwise the warp stays spatial in every round.

A repaired stamp is pinned from then on (its waypoint is the pair's point), and template points
already used by a pair (or pinned) are not reused, so a repair pair never merges with an
existing one.  After ``rounds`` rounds without conforming, :class:`ConstraintError` names
the violated constraints and the pairs that failed to fix them.  A forced waypoint whose whole
threshold ball lies inside an obstacle is contradictory from the start and is reported before
any round.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import ConstraintError
from ..core.jit import min_stamps
from .bordered import Refits
from .candidates import ball_offsets
from .noise import default_threshold
from .robust import Pairs, choose_smoothing, screen
from .route import min_energy_route
from .timing import retime
from .pathwarp import choose_warp
from .tps import MERGE_TOL, Warp

#: least clearance of an obstacle repair, a fraction of the mapped path's bounding-box diagonal
CLEARANCE = 0.01
#: a forced waypoint is met by bending the route between the held targets around it (the start,
#: the goal, an object the path touches); one that needs that stretch of route to become more
#: than this many times as long is not a deformation of the demonstrated movement but another
#: movement, and is refused, naming it and the target (option ``stretch``).  A bound, not a
#: measurement: a detour out and back to a point as far away as the stretch is long already
#: makes it about 2-3 times as long; 5 leaves room for that and refuses a via metres away
STRETCH = 5.0
#: the template's path passes through an ICP when it comes within this fraction of its
#: bounding-box diagonal (the same 1 % as OSILA's former default ball): such an ICP is a place the
#: route must go, so an obstacle over its task point contradicts it
ON_PATH = 0.01


@dataclass
class OsilaResult:
    """Everything one OSILA run produced.

    Attributes
    ----------
    path : ndarray, shape (T, D)
        The generated route.
    mapped : ndarray, shape (T, D)
        The warped template f(p_t) of the final round (the candidate ball centres).
    warp : Warp
        The final map (``warp.kind`` says whether a fallback was used).
    threshold : float
        Distortion threshold used (task units).
    rounds : int
        Rounds run (1 = the first route already conformed).
    energy : float
        Route energy Σ|q_{t+1} - q_t|² (+ distortion term).
    added : list[tuple[int, ndarray, str]]
        Repair pairs: (template index, task point, constraint that asked for it).
    retimed : dict of int to int
        On-path ICPs whose template stamp was re-estimated (:mod:`.timing`): stamp -> the template
        stamp whose point the route now has there.
    pairs : Pairs
        The ICP pairs matched, kept and rejected as outliers, and their residual (:mod:`.robust`).
    """

    path: np.ndarray
    mapped: np.ndarray
    warp: Warp
    threshold: float
    rounds: int
    energy: float
    added: list = field(default_factory=list)
    retimed: dict = field(default_factory=dict)
    pairs: Pairs | None = None


def _fmt(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.4g}" for x in p) + ")"


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) index runs where ``mask`` is true."""
    idx = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(idx[::2].tolist(), idx[1::2].tolist()))


def _contradictions(forced: np.ndarray, obstacles: np.ndarray, threshold: float, margin: float) -> list[str]:
    out = []
    for i, f in enumerate(forced):
        for o, ob in enumerate(obstacles):
            d = float(np.linalg.norm(f - ob[:-1]))
            if d + threshold <= ob[-1] + margin:
                out.append(
                    f"forced waypoint {i} at {_fmt(f)} lies inside obstacle {o} "
                    f"(centre {_fmt(ob[:-1])}, radius {ob[-1]:.4g}, margin {margin:.4g}) "
                    f"deeper than the threshold {threshold:.4g}"
                )
    return out


def on_path(path: np.ndarray, src: np.ndarray) -> np.ndarray:
    """Indices of the ICPs ``src`` (K, D) that the template ``path`` (T, D) passes through
    (within :data:`ON_PATH` of its size): the object a reach touches, a segment's boundary."""
    if not len(src):
        return np.zeros(0, int)
    size = float(np.linalg.norm(span(path)))
    gaps = np.sqrt(((path[None, :, :] - src[:, None, :]) ** 2).sum(-1)).min(1)
    return np.flatnonzero(gaps <= ON_PATH * size)


def _covered(path: np.ndarray, src: np.ndarray, dst: np.ndarray, obstacles: np.ndarray, margin: float,
             index: np.ndarray) -> list[str]:
    """ICPs the path passes through whose task point lies inside an obstacle: no route can both
    go there and keep out (reported before any round, as a contradiction)."""
    out = []
    for k in on_path(path, src):
        for o, ob in enumerate(obstacles):
            if np.linalg.norm(dst[k] - ob[:-1]) < ob[-1] + margin:
                out.append(f"ICP {index[k]} at {_fmt(dst[k])}, which the template's path passes through, lies inside "
                           f"obstacle {o} (centre {_fmt(ob[:-1])}, radius {ob[-1]:.4g}, margin {margin:.4g})")
    return out


def span(points: np.ndarray) -> np.ndarray:
    """Bounding-box side lengths (D,) of points (N, D) (``np.ptp`` along axis 0, reduced along rows)."""
    rows = np.ascontiguousarray(points.T)
    return rows.max(1) - rows.min(1)


def _segment_depths(route: np.ndarray, centre: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """How deep each straight segment between consecutive waypoints enters a sphere.

    Returns ``depth`` (T-1,) = radius - distance from ``centre`` to the segment (> 0: inside) and
    ``foot`` (T-1, D), the segment's point nearest the centre.  A one-point route has one
    "segment": the point itself.
    """
    if len(route) == 1:
        return radius - np.sqrt(((route - centre) ** 2).sum(1)), route.copy()
    a, b = route[:-1], route[1:]
    ab = b - a
    den = (ab * ab).sum(1)
    u = np.where(den > 0, ((centre - a) * ab).sum(1) / np.where(den > 0, den, 1.0), 0.0)
    foot = a + np.clip(u, 0.0, 1.0)[:, None] * ab
    return radius - np.sqrt(((foot - centre) ** 2).sum(1)), foot


def _away(point: np.ndarray, centre: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Unit vector from ``centre`` towards ``point`` (or ``fallback``, or the first axis)."""
    for p in (point, fallback):
        v = p - centre
        n = float(np.linalg.norm(v))
        if n > 1e-12:
            return v / n
    return np.eye(len(centre))[0]


def _targets(path: np.ndarray, src: np.ndarray, pinned: list, exact_pins: list, index: np.ndarray) -> dict[int, str]:
    """Stamps whose waypoint a repair must not move, with what they are: the first and the last
    (the start and the goal), the stamp nearest each ICP the template passes through
    (:func:`on_path`: the object a reach touches) and other pinned stamps, unless already pinned
    to a given point."""
    fixed = {t for t, _ in exact_pins}
    last = len(path) - 1
    out = {t: f"the waypoint at stamp {t}" for t in pinned}
    out.update({0: "the start", last: "the goal"})
    for k in on_path(path, src):
        t = int(((path - src[k]) ** 2).sum(1).argmin())
        out[t] = f"ICP {index[k]}, which the template's path passes through,"
    return {t: lab for t, lab in sorted(out.items()) if t not in fixed}


def _check_stretch(new: list, anchors: dict, names: dict, route: np.ndarray, stretch: float) -> None:
    """Refuse a forced waypoint that can be met only by stretching the route between the held
    targets around it more than ``stretch`` times (see :data:`STRETCH`), naming it and the
    target after it (the goal, or an object the path touches on the way)."""
    stamps = sorted(anchors)
    last = len(route) - 1
    steps = np.sqrt(((route[1:] - route[:-1]) ** 2).sum(1))
    length = np.concatenate([[0.0], np.cumsum(steps)])
    bad = []
    for t, q, label in new:
        if not label.startswith("forced"):
            continue
        before, after = [a for a in stamps if a < t], [b for b in stamps if b > t]
        if not before or not after:
            continue
        a, b = before[-1], after[0]
        have = max(float(length[b] - length[a]), 1e-12)
        need = float(np.linalg.norm(q - anchors[a]) + np.linalg.norm(anchors[b] - q))
        if need > stretch * have:
            which = names.get(b, "the goal" if b == last else f"the waypoint at stamp {b}")
            bad.append(f"{label} cannot be met together with {which} at {_fmt(anchors[b])}: the route from "
                       f"stamp {a} to {b} would have to be {need / have:.1f} times as long as planned "
                       f"(limit {stretch:g}, option 'stretch')")
    if bad:
        raise ConstraintError(
            "contradictory constraints: " + "; ".join(bad),
            hint="move the via nearer the movement, or bind the target elsewhere: OSILA never moves a "
                 "bound target to meet a via")


def adjust(
    path: np.ndarray,
    src: np.ndarray,
    dst: np.ndarray,
    forced: np.ndarray,
    obstacles: np.ndarray,
    *,
    threshold: float | None,
    rounds: int,
    smoothing: float,
    distortion: float,
    margin: float,
    shells: int,
    directions: int | None,
    pin: tuple[tuple[int, np.ndarray | None], ...] = (),
    timing: float = 0.0,
    stretch: float = STRETCH,
    reject: str = "auto",
    seed: int = 0,
    task_times: np.ndarray | None = None,
    precision: float | None = None,
) -> OsilaResult:
    """Run OSILA with plan adjustment on validated arrays (see the module docstring).

    Parameters
    ----------
    path : ndarray, shape (T, D)
    src, dst : ndarray, shape (K, D)
        Template and task ICPs paired by row.
    forced : ndarray, shape (F, D)
    obstacles : ndarray, shape (O, D+1)
        Sphere centres and radii.
    threshold : float or None
        Distortion threshold; None = :func:`~.noise.default_threshold` of the first mapped path.
    rounds : int
        Maximum number of rounds (>= 1).
    pin : tuple of (int, ndarray or None)
        Stamps in ``[0, T)`` whose waypoint is fixed: to the given point (D,) exactly, or, with
        None, to the stamp's mapped point.
    timing : float
        Prior spread of when the task passes an ICP on the template path (:mod:`.timing`); 0
        keeps the template's timing.
    stretch : float
        How much longer than the first route a repair may make the route between two held
        targets (:data:`STRETCH`).
    reject, seed
        Outlier rejection among the ICP pairs (:func:`.robust.screen`; pins are never screened).
    task_times : ndarray, shape (K,), optional
        When the task passes each ICP, a fraction of its duration (NaN: not known); only pairs
        with a time are re-timed (:func:`.timing.timed_stamps`).
    precision : float, optional
        How precisely the ICPs are located (task units), for the TPS's amplification limit
        (:func:`.noise.amplification_limit`); None: the template's measured noise.
    """
    T, D = path.shape
    pairs = screen(src, dst, reject, seed, threshold or 0.0, fast=T >= min_stamps())
    if len(pairs.rejected):
        src, dst = src[pairs.kept], dst[pairs.kept]
        task_times = None if task_times is None else task_times[pairs.kept]
    if smoothing == "auto":  # λ by cross-validation on the kept pairs (:func:`.robust.choose_smoothing`)
        smoothing = pairs.smoothing = choose_smoothing(src, dst)
    covered = _covered(path, src, dst, obstacles, margin, pairs.kept) if len(obstacles) else []
    if covered:
        raise ConstraintError("contradictory constraints: " + "; ".join(covered))
    given = dict(pin)
    exact_pins = [(t, q) for t, q in pin if q is not None]
    pin_src = path[[t for t, _ in exact_pins]].reshape(-1, D)
    pin_dst = np.array([q for _, q in exact_pins], dtype=float).reshape(-1, D)
    # which part of the template passes an on-path ICP: re-timed before the warp (pins never move)
    refits = Refits()  # the warp's inverses, bordered from round to round while the pairs grow
    times = None if task_times is None else np.concatenate([task_times, np.full(len(pin_src), np.nan)])
    moved = (retime(path, np.vstack([src, pin_src]), np.vstack([dst, pin_dst]), timing, fixed=tuple(given),
                    refits=refits, times=times, precision=precision)
             if len(pin_src) else retime(path, src, dst, timing, fixed=tuple(given), refits=refits, times=times,
                                         precision=precision))
    path, src = moved.path, moved.src[: len(src)]
    pairs_src, pairs_dst = src, dst
    added: list[tuple[int, np.ndarray, str]] = []
    offsets = None
    violations: list[str] = []
    for rnd in range(1, rounds + 1):
        # pins last: they win a merge with an ICP at the same template point
        if len(pin_src):
            all_src, all_dst = np.vstack([pairs_src, pin_src]), np.vstack([pairs_dst, pin_dst])
            exact = np.arange(len(all_src)) >= len(pairs_src)
        else:
            all_src, all_dst, exact = pairs_src, pairs_dst, None
        if rnd == 1 and moved.warp is not None and not smoothing:
            warp = moved.warp  # the exact warp re-timing fitted on these very pairs (nothing moved)
        else:
            # the path warp in later rounds only where the given pairs chose it: the held start and
            # goal of a repair never turn a spatial warp into a path warp halfway
            warp = choose_warp(all_src, all_dst, smoothing, exact=exact, on=path, refits=refits,
                               along=rnd == 1 or along, precision=precision)
        if rnd == 1:
            along = warp.kind == "path"
        mapped = warp.mapped
        if rnd == 1:
            # an ICP whose template point IS a waypoint (a boundary, a sub-template's start or end)
            # is met exactly at that stamp; explicit pins win
            met = {t: warp.dst[k] for t, k in warp.at.items()}
            met.update((t, q) for t, q in given.items() if q is not None)
            exact_pins = list(met.items())
            pinned = sorted({0, T - 1, *met, *given})  # the ends: the mapped start and goal
        if offsets is None:
            if threshold is None:
                threshold = default_threshold(mapped)
            bad = _contradictions(forced, obstacles, threshold, margin)
            if bad:
                raise ConstraintError("contradictory constraints: " + "; ".join(bad))
            offsets = ball_offsets(D, threshold, shells, directions)
            # (only an obstacle repair uses it)
            clearance = (max(threshold, CLEARANCE * float(np.linalg.norm(span(mapped)))) if len(obstacles)
                         else 0.0)
        blocked = None
        if len(obstacles):
            cand = mapped[:, None, :] + offsets[None, :, :]  # (T, M, D)
            blocked = np.zeros(cand.shape[:2], bool)
            for ob in obstacles:
                blocked |= ((cand - ob[:-1]) ** 2).sum(-1) < (ob[-1] + margin) ** 2
        choice, energy = min_energy_route(mapped, offsets, distortion, blocked, pinned=pinned)
        route = offsets.take(choice, axis=0)  # offsets[choice], 2 us instead of 11 at T = 1000
        route += mapped  # (the same sums as mapped + offsets[choice])
        for t, q in exact_pins:
            route[t] = q  # the warp meets it up to rounding; make it exact
        if not len(forced) and not len(obstacles):
            return OsilaResult(route, mapped, warp, threshold, rnd, energy, added, moved.stamps, pairs)
        # template indices already pinned by a pair (never reuse them)
        eps = MERGE_TOL * float(span(np.vstack([path, src])).max())
        used = np.zeros(T, bool)
        used[pinned] = True
        for s in pairs_src:
            used |= ((path - s) ** 2).sum(1) <= eps * eps
        violations, new = [], []
        for i, f in enumerate(forced):
            dist = np.sqrt(((route - f) ** 2).sum(1))
            if dist.min() > threshold * (1 + 1e-9) + 1e-12:
                label = f"forced waypoint {i} at {_fmt(f)}"
                violations.append(f"{label} missed by {dist.min():.4g} (threshold {threshold:.4g})")
                d_map = ((mapped - f) ** 2).sum(1)
                d_map[used] = np.inf
                if np.isfinite(d_map).any():
                    t = int(d_map.argmin())
                    used[t] = True
                    new.append((t, f.copy(), label))
        for o, ob in enumerate(obstacles):
            c, r = ob[:-1], ob[-1] + margin
            depth, foot = _segment_depths(route, c, r)
            inside = depth > 1e-12 * max(r, 1.0)
            if not inside.any():
                continue
            label = f"obstacle {o} (centre {_fmt(c)}, radius {ob[-1]:.4g})"
            runs = _runs(inside)
            last = len(route) - 1
            violations.append(f"{label} entered between stamps " + ", ".join(
                f"{a}-{min(b, last)}" for a, b in runs))
            for a, b in runs:
                # the deepest segment [k, k+1] of the run that still has a waypoint free to move
                for k in a + np.argsort(-depth[a:b], kind="stable"):
                    ends = [int(k)] if len(route) == 1 else [int(k), int(k) + 1]
                    near = [t for t in ends if np.allclose(route[t], foot[k])]
                    if near:  # a waypoint is the nearest point: push it radially out
                        t = near[0]
                        if used[t]:
                            continue
                        used[t] = True
                        new.append((t, c + _away(route[t], c, mapped[t]) * (r + clearance), label))
                        break
                    free = [t for t in ends if not used[t]]
                    if not free:
                        continue
                    # the segment passes through: move its ends out, parallel, past the sphere
                    shift = _away(foot[k], c, mapped[k]) * (depth[k] + clearance)
                    for t in free:
                        used[t] = True
                        new.append((t, route[t] + shift, label))
                    break
        if not violations:
            return OsilaResult(route, mapped, warp, threshold, rnd, energy, added, moved.stamps, pairs)
        if not new:
            break
        if rnd == 1:
            # the targets are held where the first route put them: a repair bends the route
            # between them, it never moves them (never trades the goal for a via or an avoid)
            held = _targets(path, src, pinned, exact_pins, pairs.kept)
            for t in held:
                used[t] = True
            new = [(t, q, lab) for t, q, lab in new if t not in held]
            hold = {t: route[t].copy() for t in held}
            anchors = {**dict(exact_pins), **hold}
            _check_stretch(new, anchors, held, route, stretch)
            if hold:
                pin_src = np.vstack([pin_src, path[list(hold)]])
                pin_dst = np.vstack([pin_dst, np.array(list(hold.values()))])
                exact_pins = exact_pins + list(hold.items())
                pinned = sorted({*pinned, *hold})
            if not new:
                break
        added.extend(new)
        pinned = sorted({*pinned, *(t for t, _, _ in new)})  # a repaired waypoint stays where the pair puts it
        pairs_src = np.vstack([pairs_src, path[[t for t, _, _ in new]]])
        pairs_dst = np.vstack([pairs_dst, np.array([q for _, q, _ in new])])
    shown = 5  # a hopeless constraint can add a pair per stamp: name the first few only
    tried = "; ".join(f"template[{t}] {_fmt(path[t])} -> {_fmt(q)} for {lab}" for t, q, lab in added[:shown]) or "none"
    if len(added) > shown:
        tried += f"; and {len(added) - shown} more"
    raise ConstraintError(
        f"the route could not conform after {rnd} round(s): " + "; ".join(violations)
        + f". Constraint pairs tried: {tried}",
        hint="raise 'rounds' or 'threshold', or remove one of the contradicting constraints",
    )
