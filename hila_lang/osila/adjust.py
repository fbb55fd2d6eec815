"""Iterative plan adjustment: warp, route, check, add constraint pairs, repeat (DESIGN.md §1.3).

Each round fits the warp on the ICP pairs plus the pairs added so far, maps the template, picks
the minimum-energy route through the candidate balls (candidates inside an obstacle are excluded
up front), and checks the route:

- a *forced waypoint* is violated when no route point lies within ``threshold`` of it; the repair
  pair is (template point whose mapped point is nearest the forced point -> the forced point);
- a *pinned* stamp (option ``pin``) keeps its mapped point (only the centre candidate), e.g.
  the start of a sub-template bound to where the hand is;
- an *obstacle* (sphere) is violated when a route point lies closer than ``radius + margin`` to
  its centre; for each run of consecutive violating stamps the deepest one gets the repair pair
  (its template point -> the point pushed radially out to ``radius + margin + threshold``, so
  that its whole candidate ball is outside).

Template points already used by a pair are not reused, so a repair pair never merges with an
existing one.  After ``rounds`` rounds without conforming, :class:`ConstraintError` names the
violated constraints and the pairs that failed to fix them.  A forced waypoint whose whole
threshold ball lies inside an obstacle is contradictory from the start and is reported before
any round.  Only waypoints are checked, not the straight segments between them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConstraintError
from .candidates import ball_offsets
from .route import min_energy_route
from .tps import MERGE_TOL, Warp, fit_warp


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
    """

    path: np.ndarray
    mapped: np.ndarray
    warp: Warp
    threshold: float
    rounds: int
    energy: float
    added: list = field(default_factory=list)


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


def default_threshold(mapped: np.ndarray, fraction: float = 0.01) -> float:
    """``fraction`` of the bounding-box diagonal of the mapped path (0 for a single point)."""
    return float(fraction * np.linalg.norm(np.ptp(mapped, axis=0)))


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
    pin: tuple[int, ...] = (),
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
        Distortion threshold; None = :func:`default_threshold` of the first mapped path.
    rounds : int
        Maximum number of rounds (>= 1).
    pin : tuple of int
        Stamps (valid indices, negative allowed) whose waypoint is the mapped point itself.
    """
    T, D = path.shape
    extent = float(np.ptp(np.vstack([path, src]), axis=0).max())
    eps = MERGE_TOL * extent
    pairs_src, pairs_dst = src, dst
    added: list[tuple[int, np.ndarray, str]] = []
    offsets = None
    violations: list[str] = []
    for rnd in range(1, rounds + 1):
        warp = fit_warp(pairs_src, pairs_dst, smoothing)
        mapped = warp(path)
        if offsets is None:
            if threshold is None:
                threshold = default_threshold(mapped)
            bad = _contradictions(forced, obstacles, threshold, margin)
            if bad:
                raise ConstraintError("contradictory constraints: " + "; ".join(bad))
            offsets = ball_offsets(D, threshold, shells, directions)
        blocked = None
        if pin:
            blocked = np.zeros((T, len(offsets)), bool)
            blocked[list(pin), 1:] = True
        if len(obstacles):
            cand = mapped[:, None, :] + offsets[None, :, :]  # (T, M, D)
            if blocked is None:
                blocked = np.zeros(cand.shape[:2], bool)
            for ob in obstacles:
                blocked |= ((cand - ob[:-1]) ** 2).sum(-1) < (ob[-1] + margin) ** 2
        choice, energy = min_energy_route(mapped, offsets, distortion, blocked)
        route = mapped + offsets[choice]
        # template indices already pinned by a pair (never reuse them)
        used = np.zeros(T, bool)
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
            depth = r - np.sqrt(((route - c) ** 2).sum(1))
            inside = depth > 0
            if not inside.any():
                continue
            label = f"obstacle {o} (centre {_fmt(c)}, radius {ob[-1]:.4g})"
            runs = _runs(inside)
            violations.append(f"{label} entered at stamps " + ", ".join(f"{a}-{b - 1}" for a, b in runs))
            for a, b in runs:
                sub = depth[a:b].copy()
                sub[used[a:b]] = -np.inf
                if not np.isfinite(sub).any():
                    continue
                t = a + int(sub.argmax())
                away = route[t] - c
                n = float(np.linalg.norm(away))
                if n < 1e-12:
                    away, n = mapped[t] - c, float(np.linalg.norm(mapped[t] - c))
                direction = away / n if n > 1e-12 else np.eye(D)[0]
                used[t] = True
                new.append((t, c + direction * (r + threshold), label))
        if not violations:
            return OsilaResult(route, mapped, warp, threshold, rnd, energy, added)
        if not new:
            break
        added.extend(new)
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
