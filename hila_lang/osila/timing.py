"""Re-timing: which part of the template's shape passes an ICP that lies on the template path?

An ICP whose template point is a point of the template path, at stamp t_k (a segment boundary,
a point at a time fraction), says where the task's movement passes: the task point q_k.  It says
WHEN only if the pair carries the task's time too (option ``task_times`` of
:func:`hila_lang.osila.imitate`: when the task passed q_k, a fraction τ_k of its duration) — a
boundary of an equal-time split, a point at a time fraction.  A scene ICP, a via point, a point
at a fraction of the drawn length carry no time: they are correspondences in position only, and
re-timing them would pay for a correspondence in time that is not there (on LASA's leak-free
protocol, where the pairs are at fractions of arc length, re-timing them cost 0.07–0.18 of mean
Fréchet distance; ``docs/evaluation.md``).  So only pairs that carry a time are re-timed, and only
while their timing agrees with the template (:func:`timed_stamps`, the test stated there): the
pairs' task times in the order of their template stamps, and each task time within the
re-timing window (±4 σ_t) of its template point's own time t_k / (T - 1).  A pair whose task time
lies outside the window does not pair the template's point at a time with the task's at the
same time; it is a position, and kept.

For a pair that carries a time and agrees: it says the task's movement passes q_k, and does so
at (about) time t_k.  People do not repeat a movement's timing: the same stroke peaks in speed
earlier or later (time to peak speed 42–57 % of a reach, MacKenzie et al. 1987), so the
template's point at t_k is in general not the point of the template's *shape* that passes q_k.
An exact warp through (template point at t_k → q_k) then bends the shape to make up for a
difference in timing — the larger the difference, the more — and the route follows the bent
shape.

So before the warp each such pair's template stamp is estimated again, as the most probable one
given the pairs (maximum a posteriori):

    t*_k = argmin_t  E(pairs, with template point p_t for pair k) / (2 λ)  +  (t − t_k)² / (2 (σ_t (T − 1))²)

- ``E`` is the distortion energy of the map OSILA fits to the pairs (the paper's criterion,
  minimal distortion): the bending energy of the thin plate spline when :func:`~.tps.fit_warp`
  chooses it, else the residual sum of squares of the least-squares similarity (the part of the
  pairs a rigid placement does not explain);
- ``λ`` = E at the given stamps divided by its degrees of freedom: the scale of distortion the
  pairs themselves show, so a template that fits the task badly everywhere (a different movement)
  gains little by sliding its pairs;
- ``σ_t`` (option ``timing``, a fraction of the movement's duration) is the prior spread of
  *when*.  Its default :data:`TIMING` = 0.03 is the widest prior that leaves the stand-in's
  cross-mapping of *different* movements (Experiment A across set-ups, where there is no timing
  to recover) no worse on mean Fréchet distance than keeping the stamps, measured by
  ``bench/route.py --timing``; the same run shows what it gains on pairs of the same movement.

The pairs are visited in time order, each stamp strictly between its neighbours' (the movement's
order is kept) and within ±4 σ_t of its own, until no stamp changes.  The template is then
re-timed, piecewise linearly in time, so that template stamp t*_k falls at stamp t_k: the route
still passes q_k exactly at stamp t_k — the pair's time is kept; which part of the template's
shape is there changes.  The first and last stamps, pinned stamps and pairs that share a stamp
never move; with ``timing`` = 0 nothing does.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from .pathwarp import choose_warp
from .tps import Warp, _dist, _tol, affine_rank, kernel

#: default prior spread σ_t of when the task passes an on-path ICP, a fraction of the duration
TIMING = 0.03
#: candidate stamps lie within this many σ_t of a pair's own stamp (the prior beyond is < 1e-3)
WINDOW = 4.0
MAX_SWEEPS = 10


@dataclass
class Retimed:
    """A re-timed template.

    Attributes
    ----------
    path : ndarray, shape (T, D)
        The template re-timed: ``path[t_k]`` is template point ``t*_k`` for every moved pair.
    src : ndarray, shape (K, D)
        The template ICPs, moved pairs replaced by their new template points.
    stamps : dict of int to int
        Moved pairs: stamp t_k -> the template stamp t*_k now at t_k.
    warp : Warp or None
        When nothing moved but a warp was fitted to decide (exact, on ``path``): that warp, which
        the caller may reuse.
    """

    path: np.ndarray
    src: np.ndarray
    stamps: dict
    warp: Warp | None = None


def _similarity_ss(S: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """Least-squares similarity residual Σ|Y − s R S_k − c|² per candidate set, S (B, K, D), Y (K, D)."""
    a = S - S.mean(1, keepdims=True)
    b = Y - Y.mean(0)
    var_a = (a * a).sum((1, 2))
    var_b = float((b * b).sum())
    if S.shape[2] == 2:
        za, zb = a[..., 0] + 1j * a[..., 1], b[:, 0] + 1j * b[:, 1]
        fit = np.abs((za.conj() * zb).sum(1)) ** 2
    else:
        cov = np.einsum("kd,bke->bde", b, a)
        U, s, Vt = np.linalg.svd(cov)
        s[:, -1] *= np.sign(np.linalg.det(U) * np.linalg.det(Vt))
        fit = s.sum(1) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(var_a > 0, var_b - fit / var_a, np.inf)


def _bending(S: np.ndarray, Y: np.ndarray, mu: np.ndarray, sc: float) -> np.ndarray:
    """Bending energy Σ_d w_dᵀ y_d of the exact TPS through each candidate set (normalised by mu, sc)."""
    B, K, D = S.shape
    X = (S - mu) / sc
    n = K + D + 1
    A = np.zeros((B, n, n))
    diff = X[:, :, None, :] - X[:, None, :, :]
    A[:, :K, :K] = kernel(np.sqrt((diff * diff).sum(-1)), D)
    A[:, :K, K] = A[:, K, :K] = 1.0
    A[:, :K, K + 1:] = X
    A[:, K + 1:, :K] = X.transpose(0, 2, 1)
    rhs = np.zeros((B, n, D))
    rhs[:, :K] = Y
    sol = np.full((B, n, D), np.nan)
    with np.errstate(all="ignore"):
        try:
            sol = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:  # a candidate that coincides with another pair: singular, never chosen
            for b in range(B):
                try:
                    sol[b] = np.linalg.solve(A[b], rhs[b])
                except np.linalg.LinAlgError:
                    pass
    E = (sol[:, :K] * Y).sum((1, 2))
    return np.where(np.isfinite(E), E, np.inf)


def timed_stamps(path: np.ndarray, src: np.ndarray, times, timing: float) -> set[int]:
    """Stamps of the on-path pairs that carry a task time agreeing with the template (module docstring).

    A pair carries a time when its entry of ``times`` (K,) is finite (the task's time, a fraction of
    its duration in [0, 1]) and its template point is a point of ``path`` (T, D), at stamp t.  The
    test: (1) ordered by their stamps, the pairs' task times never decrease (else the timing
    contradicts the path's order, and no pair is re-timed); (2) a pair's task time lies within
    :data:`WINDOW` σ_t (``timing``) of t / (T - 1), its template point's own time.
    """
    if times is None:
        return set()
    times = np.asarray(times, dtype=float)
    T = len(path)
    if T < 3 or timing <= 0 or not np.isfinite(times).any():
        return set()
    have = np.flatnonzero(np.isfinite(times))
    r = _dist(src[have], path)
    near = r.argmin(1)
    on = r[np.arange(len(have)), near] <= _tol(path, src)
    stamp = {int(near[i]): float(times[k]) for i, k in enumerate(have) if on[i]}
    order = sorted(stamp)
    if any(stamp[b] < stamp[a] for a, b in zip(order, order[1:])):
        return set()
    return {t for t in order if abs(stamp[t] - t / (T - 1.0)) <= WINDOW * timing}


def retime(path: np.ndarray, src: np.ndarray, dst: np.ndarray, timing: float,
           fixed: tuple[int, ...] = (), refits=None, times=None, precision: float | None = None) -> Retimed:
    """Re-estimate the template stamps of on-path pairs (module docstring) and re-time the template.

    Parameters
    ----------
    path : ndarray, shape (T, D)
        Template path.
    src, dst : ndarray, shape (K, D)
        All pairs the warp will be fitted on (ICPs, then pins).
    timing : float
        σ_t, a fraction of the duration; 0 moves nothing.
    fixed : tuple of int
        Stamps that never move (pinned stamps); the first and last stamps never move either.
    refits : :class:`.bordered.Refits`, optional
        Where the warp fitted to decide keeps its factorisation for plan adjustment's rounds.
    times : array_like, shape (K,), optional
        When the task passes each pair, a fraction of its duration (NaN: not known).  Only pairs
        with a time that agrees (:func:`timed_stamps`) are re-timed; none without ``times``.
    precision : float, optional
        The pairs' precision for the warp's amplification limit (:func:`.pathwarp.choose_warp`).

    Returns
    -------
    Retimed
        The inputs themselves (not copies) when nothing moved, with the exact warp fitted to decide.
    """
    T, D = path.shape
    timed = timed_stamps(path, src, times, timing)
    if not timed:
        return Retimed(path, src, {})
    warp = choose_warp(src, dst, on=path, refits=refits, precision=precision)
    unchanged = Retimed(path, src, {}, warp)
    # pairs (rows of warp.src, after merging) whose template point is the path's point at one stamp
    count = Counter(warp.at.values())
    blocked = {0, T - 1, *fixed}
    inner = sorted((t, k) for t, k in warp.at.items() if count[k] == 1 and t not in blocked and t in timed)
    if not inner:
        return unchanged
    K = len(warp.src)
    if warp.kind == "tps":
        dof = D * (K - D - 1)
    elif warp.kind in ("similarity", "path") and affine_rank(warp.src) == D:
        dof = D * K - (4 if D == 2 else 7)
    else:
        return unchanged
    if dof <= 0:
        return unchanged
    mu, sc = warp.src.mean(0), float(np.abs(warp.src - warp.src.mean(0)).max())

    def energies(current: np.ndarray, row: int, cand: np.ndarray) -> np.ndarray:
        S = np.repeat(current[None], len(cand), axis=0)
        S[:, row] = path[cand]
        return _bending(S, warp.dst, mu, sc) if warp.kind == "tps" else _similarity_ss(S, warp.dst)

    current = warp.src.copy()
    E0 = float(energies(current, inner[0][1], np.array([inner[0][0]]))[0])
    if not np.isfinite(E0) or E0 <= 0:
        return unchanged
    lam = E0 / dof
    span = timing * (T - 1)
    reach = int(np.ceil(WINDOW * span))
    knots = sorted(blocked | set(warp.at))  # stamps in time order; only ``inner`` ones move
    star = {t: t for t in knots}
    for _ in range(MAX_SWEEPS):
        changed = False
        for t, k in inner:
            i = knots.index(t)
            lo = max(star[knots[i - 1]] + 1, t - reach)
            hi = min(star[knots[i + 1]] - 1, t + reach)
            if hi <= lo:
                continue
            cand = np.arange(lo, hi + 1)
            cost = energies(current, k, cand) / (2.0 * lam) + (cand - t) ** 2 / (2.0 * span * span)
            best = int(cand[int(np.argmin(cost))])
            if best != star[t]:
                star[t] = best
                current[k] = path[best]
                changed = True
        if not changed:
            break
    moved = {t: s for t, s in star.items() if s != t}
    if not moved:
        return unchanged
    stamps = np.arange(T, dtype=float)
    phase = np.interp(stamps, np.array(knots, float), np.array([star[t] for t in knots], float))
    new_path = np.column_stack([np.interp(phase, stamps, path[:, d]) for d in range(D)])
    new_src = src.copy()
    tol = _tol(path, src)
    for t, s in moved.items():
        new_path[t] = path[s]
        new_src[_dist(src, path[t : t + 1])[:, 0] <= tol] = path[s]  # every row the warp merged into it
    return Retimed(new_path, new_src, moved)
