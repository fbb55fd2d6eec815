"""Minimum-energy route: Viterbi over time stamps, one candidate waypoint per stamp.

Candidates at stamp t are ``centres[t] + offsets[i]`` (the same offsets at every stamp).  The
route minimises

    E = Σ_t |q_{t+1} - q_t|²  +  distortion · Σ_t |q_t - centres[t]|²

(translational energy at constant Δt, plus an optional distortion term).  Candidates flagged in
``blocked`` are excluded.  Writing q = c + o, the step cost splits into
|Δc_t|² + 2Δc_t·(o_j - o_i) + |o_j - o_i|²: the last term is one (M, M) matrix G for all stamps
and the linear terms are known for all stamps up front.  With W[t] = V[t] - 2Δc_t·o (the
cost-to-here with the outgoing linear term applied) one forward step is

    W[t+1][j] = min_i (W[t][i] + G[i, j]) + c[t][j],   c[t] = 2Δc_t·o + unary[t+1] - 2Δc_{t+1}·o

O(T·M²) work in all.  Two implementations compute exactly the same sums in the same order, so
they return the same route, ties included:

- a compiled kernel (:func:`_route_kernel`, numba via :mod:`hila_lang.core.jit`) for paths of at least
  :data:`hila_lang.core.jit.MIN_STAMPS` stamps: about 0.09 ms for T = 1000 and M = 17 candidates
  in a ball of 1 % of the path's size, 0.05 ms in OSILA's default ball on a clean path (0.17 ms
  for both before issue 38's second pass).  Its minimum over the previous candidates skips those
  that cannot win, exactly (rounding is monotone): where the cheapest previous candidate's way
  costs no more than the second cheapest previous cost, it is the minimum (the usual case in a
  narrow ball, whose distances are tiny against the costs' differences); otherwise it visits the
  candidates by increasing offset distance, stopping once the cheapest previous cost plus that
  distance is no better.  Its work array comes from numpy: on the ``bench/osila.py`` paths 2 ms
  instead of 4.7 ms at T = 10000, M = 29;
- numpy (:func:`_route_numpy`): T - 1 short vectorised steps, for shorter paths and when numba
  is missing or ``HILA_JIT=0`` (about 20× slower on long paths).

:func:`min_energy_route_reference` is the slow, obvious version the tests compare both against.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core import jit
from ..core.jit import min_stamps


def _route_numpy(centres, offsets, base, extra, pinned, choice) -> float:
    """Fill ``choice`` (T,) with the optimal candidates; return min W[T-1] (see the module docstring).

    The unary cost of candidate j at stamp t is ``base[j] + extra[t, j]`` (``extra`` of one row:
    the same row at every stamp), and infinite for j > 0 where ``pinned[t]``.
    """
    T, D = centres.shape
    unary = base + extra if len(extra) == T else np.repeat((base + extra[0])[None], T, axis=0)
    unary[pinned, 1:] = np.inf
    step = centres[1:] - centres[:-1]
    dot = step[:, 0:1] * offsets[:, 0]
    for d in range(1, D):
        dot = dot + step[:, d : d + 1] * offsets[:, d]
    lin = 2.0 * dot  # (T-1, M)
    diff = offsets[:, None, 0] - offsets[None, :, 0]
    G = diff * diff
    for d in range(1, D):
        diff = offsets[:, None, d] - offsets[None, :, d]
        G = G + diff * diff  # (M, M), symmetric
    c = lin + unary[1:]
    c[:-1] = c[:-1] - lin[1:]
    w = unary[0] - lin[0] if T > 1 else unary[0].copy()
    rows = [w]
    for ct in c:
        w = np.minimum.reduce(w + G, axis=1)  # G symmetric: row j holds G[i, j] over i
        w += ct
        rows.append(w)
    W = np.array(rows)
    choice[-1] = int(W[-1].argmin())
    for t in range(T - 1, 0, -1):
        choice[t - 1] = int((W[t - 1] + G[choice[t]]).argmin())
    return float(W[-1, choice[-1]])


def _route_kernel(centres, offsets, base, extra, pinned, choice, W):  # pragma: no cover - compiled by numba
    """:func:`_route_numpy` as explicit loops: the same sums in the same order, the same minima.

    ``W`` (T, M) is work space the caller allocates (numpy reuses large blocks; an allocation
    inside the kernel paid ~1.6 ms of fresh pages at T = 10000, M = 29 here).  The forward pass
    keeps only the values W (a running minimum over the previous candidates, pruned: below); the
    back-pointers are recomputed along the chosen route only, from the same sums (first minimum).
    The linear terms are formed a stamp ahead, never stored for the whole path.
    """
    T, D = centres.shape
    M = offsets.shape[0]
    per_stamp = extra.shape[0] == T and T > 1
    G = np.empty((M, M))
    for i in range(M):
        for j in range(M):
            diff = offsets[i, 0] - offsets[j, 0]
            g = diff * diff
            for d in range(1, D):
                diff = offsets[i, d] - offsets[j, d]
                g = g + diff * diff
            G[i, j] = g
    # near[j]: the candidates i by increasing G[i, j] (j itself first), for the pruned minimum
    near = np.empty((M, M), dtype=np.intp)
    gap = np.full(M, np.inf)  # G to the nearest other candidate
    gs = np.empty((M, M))  # gs[j, k] = G[near[j, k], j]: the visit's distances, in order
    for j in range(M):
        near[j] = np.argsort(G[:, j], kind="mergesort")
        for k in range(M):
            gs[j, k] = G[near[j, k], j]
        if M > 1:
            gap[j] = gs[j, 1]
    more = np.empty(M, dtype=np.bool_)
    oT = np.ascontiguousarray(offsets.T)
    step = np.empty(D)
    lin = np.empty(M)  # the linear terms of step t
    lin_next = np.empty(M)  # ... of step t + 1
    if T > 1:
        for d in range(D):
            step[d] = centres[1, d] - centres[0, d]
        for j in range(M):
            dot = step[0] * offsets[j, 0]
            for d in range(1, D):
                dot = dot + step[d] * offsets[j, d]
            lin[j] = 2.0 * dot
    for j in range(M):
        u = base[j] + extra[0, j] if j == 0 or not pinned[0] else np.inf
        W[0, j] = u - lin[j] if T > 1 else u
    nxt = np.empty(M)
    lows = np.empty(T)  # min_i W[t, i]
    for t in range(T - 1):
        # the lowest W[t, i] (the first such i) and the second lowest
        first = 0
        low = W[t, 0]
        low2 = np.inf
        for i in range(1, M):
            w = W[t, i]
            if w < low:
                low2 = low
                low = w
                first = i
            elif w < low2:
                low2 = w
        lows[t] = low
        # min_i W[t, i] + G[i, j], visiting i by increasing G[i, j] (i = j first: W[t, j] + 0):
        # once low + G[i, j] >= the best so far, no later i can be smaller (W[t, i] >= low, G
        # grows, rounding is monotone), so the minimum is the number the full scan gives, with a
        # fraction of the work on a smooth path (on average 1 to 6 candidates of 29 per j here).
        # First, without branches, the usual case: the nearest other candidate cannot beat j's own
        for j in range(M):
            nxt[j] = W[t, j]
            more[j] = low + gap[j] < W[t, j]
        # the cheapest previous candidate's way: no other can beat it where it costs no more than
        # the second lowest W[t, i] (W[t, i] + G >= W[t, i] >= low2, G >= 0).  The usual case
        # when the ball is narrow against a step (OSILA's default ball on a clean path: G ~
        # threshold² is tiny against the differences of W, and the scan below, which stops on G,
        # would visit every candidate); not tried at a stamp where even its nearest other
        # candidate costs more than low2 (a wide ball)
        narrow = low + gap[first] <= low2
        for j in range(M):
            if not more[j]:
                continue
            if narrow:
                best = W[t, first] + G[first, j]
                if best <= low2:
                    nxt[j] = best
                    continue
            best = nxt[j]
            for k in range(1, M):
                g = gs[j, k]
                if low + g >= best:
                    break
                v = W[t, near[j, k]] + g
                best = v if v < best else best
            nxt[j] = best
        r = t + 1 if per_stamp else 0
        if t + 2 < T:  # (loops over j innermost, without branches: vectorised)
            for d in range(D):
                step[d] = centres[t + 2, d] - centres[t + 1, d]
            for j in range(M):
                lin_next[j] = step[0] * oT[0, j]
            for d in range(1, D):
                for j in range(M):
                    lin_next[j] = lin_next[j] + step[d] * oT[d, j]
            for j in range(M):
                lin_next[j] = 2.0 * lin_next[j]
            for j in range(M):
                W[t + 1, j] = nxt[j] + ((lin[j] + (base[j] + extra[r, j])) - lin_next[j])
        else:
            for j in range(M):
                W[t + 1, j] = nxt[j] + (lin[j] + (base[j] + extra[r, j]))
        if pinned[t + 1]:  # only the centre: the others' unary cost is infinite
            for j in range(1, M):
                W[t + 1, j] = np.inf
        lin, lin_next = lin_next, lin
    last = 0
    for j in range(1, M):
        if W[T - 1, j] < W[T - 1, last]:
            last = j
    choice[T - 1] = last
    for t in range(T - 1, 0, -1):
        # the first i minimising W[t - 1, i] + G[i, j], pruned as the forward pass (every i
        # that ties the minimum has lows[t - 1] + G[i, j] <= it, so it is visited)
        j = choice[t]
        arg = j
        best = W[t - 1, j] + G[j, j]
        for k in range(1, M):
            i = near[j, k]
            g = gs[j, k]
            if lows[t - 1] + g > best:
                break
            v = W[t - 1, i] + g
            if v < best or (v == best and i < arg):
                best = v
                arg = i
        choice[t - 1] = arg
    return W[T - 1, last]


#: example arguments the kernel is compiled and tried on (made once: a call asks for the kernel)
_WARM = (np.zeros((3, 2)), np.zeros((2, 2)), np.zeros(2), np.zeros((1, 2)), np.zeros(3, dtype=np.bool_),
         np.zeros(3, dtype=np.intp), np.zeros((3, 2)))


def _compiled_route():
    return jit.compiled(_route_kernel, *_WARM)


def min_energy_route(
    centres: np.ndarray,
    offsets: np.ndarray,
    distortion: float = 0.0,
    blocked: np.ndarray | None = None,
    *,
    pinned: Any = (),
) -> tuple[np.ndarray, float]:
    """Choose one candidate per stamp minimising the route energy.

    Parameters
    ----------
    centres : ndarray, shape (T, D)
        Mapped template points f(p_t).
    offsets : ndarray, shape (M, D)
        Candidate offsets (see :mod:`.candidates`).
    distortion : float
        Weight of the distortion term (>= 0).
    blocked : ndarray of bool, shape (T, M), optional
        Candidates that may not be chosen.  A stamp whose candidates are all blocked is treated
        as unblocked (the caller detects and repairs the violation).
    pinned : sequence of int
        Stamps where only candidate 0 (the centre, the mapped point itself) may be chosen.

    Returns
    -------
    choice : ndarray of int, shape (T,)
        Index into ``offsets`` per stamp; the route is ``centres + offsets[choice]``.
    energy : float
        E of the chosen route.
    """
    centres = np.ascontiguousarray(centres, dtype=float)
    offsets = np.ascontiguousarray(offsets, dtype=float)
    T, M = centres.shape[0], offsets.shape[0]
    base = distortion * (offsets * offsets).sum(1)
    if blocked is None:
        extra = np.zeros((1, M))
    else:
        free = ~blocked
        free[~free.any(1)] = True
        extra = np.where(free, 0.0, np.inf)
    pin = np.zeros(T, dtype=np.bool_)
    pin[list(pinned)] = True
    if len(extra) == T and pin.any():
        extra[pin, 0] = 0.0  # a pinned stamp keeps its centre, blocked or not
    choice = np.empty(T, dtype=np.intp)
    kernel = _compiled_route() if T >= min_stamps() else None
    if kernel is None:
        best = _route_numpy(centres, offsets, base, extra, pin, choice)
    else:
        best = kernel(centres, offsets, base, extra, pin, choice, np.empty((T, M)))
    step = centres[1:] - centres[:-1]
    return choice, float(best + np.einsum("ij,ij->", step, step))


def route_energy(route: np.ndarray, centres: np.ndarray, distortion: float = 0.0) -> float:
    """E of a given route (T, D) around ``centres`` (T, D)."""
    return float((np.diff(route, axis=0) ** 2).sum() + distortion * ((route - centres) ** 2).sum())


def min_energy_route_reference(
    centres: np.ndarray,
    offsets: np.ndarray,
    distortion: float = 0.0,
    blocked: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """Slow, obvious Viterbi with explicit loops over stamps and candidate pairs (for tests)."""
    T, M = centres.shape[0], offsets.shape[0]
    allowed = np.ones((T, M), bool) if blocked is None else ~blocked
    for t in range(T):
        if not allowed[t].any():
            allowed[t] = True
    cand = [[centres[t] + offsets[i] for i in range(M)] for t in range(T)]
    inf = float("inf")
    cost = [[inf] * M for _ in range(T)]
    back = [[0] * M for _ in range(T)]
    for i in range(M):
        if allowed[0][i]:
            cost[0][i] = distortion * float(np.dot(offsets[i], offsets[i]))
    for t in range(1, T):
        for j in range(M):
            if not allowed[t][j]:
                continue
            best, arg = inf, 0
            for i in range(M):
                d = cand[t][j] - cand[t - 1][i]
                c = cost[t - 1][i] + float(np.dot(d, d))
                if c < best:
                    best, arg = c, i
            cost[t][j] = best + distortion * float(np.dot(offsets[j], offsets[j]))
            back[t][j] = arg
    last = int(np.argmin(cost[T - 1]))
    choice = [last]
    for t in range(T - 1, 0, -1):
        choice.append(back[t][choice[-1]])
    return np.array(choice[::-1]), float(cost[T - 1][last])
