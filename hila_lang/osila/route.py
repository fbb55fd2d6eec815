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

- a compiled kernel (:func:`_route_kernel`, numba via :mod:`hila_lang.jit`) — the default, about
  0.2 ms for T = 1000 stamps and M = 17 candidates;
- numpy (:func:`_route_numpy`): T - 1 short vectorised steps, used when numba is missing or
  ``HILA_JIT=0`` (about 20× slower on long paths).

:func:`min_energy_route_reference` is the slow, obvious version the tests compare both against.
"""

from __future__ import annotations

import numpy as np


def _route_numpy(centres, offsets, unary, choice) -> float:
    """Fill ``choice`` (T,) with the optimal candidates; return min W[T-1] (see the module docstring)."""
    T, D = centres.shape
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


def _route_kernel(centres, offsets, unary, choice):  # pragma: no cover - compiled by numba (hila_lang.jit)
    """:func:`_route_numpy` as explicit loops: the same sums in the same order, first-minimum ties.

    The forward pass keeps only the values W (an elementwise running minimum over the previous
    candidates, which the compiler vectorises); the back-pointers are recomputed along the chosen
    route only, from the same sums.
    """
    T, D = centres.shape
    M = offsets.shape[0]
    G = np.empty((M, M))
    for i in range(M):
        for j in range(M):
            diff = offsets[i, 0] - offsets[j, 0]
            g = diff * diff
            for d in range(1, D):
                diff = offsets[i, d] - offsets[j, d]
                g = g + diff * diff
            G[i, j] = g
    lin = np.empty(M)
    nxt_lin = np.empty(M)
    W = np.empty((T, M))
    nxt = np.empty(M)
    if T > 1:
        for j in range(M):
            dot = (centres[1, 0] - centres[0, 0]) * offsets[j, 0]
            for d in range(1, D):
                dot = dot + (centres[1, d] - centres[0, d]) * offsets[j, d]
            lin[j] = 2.0 * dot
            W[0, j] = unary[0, j] - lin[j]
    else:
        for j in range(M):
            W[0, j] = unary[0, j]
    for t in range(T - 1):
        for j in range(M):
            nxt[j] = W[t, 0] + G[0, j]
        for i in range(1, M):
            wi = W[t, i]
            for j in range(M):
                nxt[j] = min(nxt[j], wi + G[i, j])
        for j in range(M):
            ct = lin[j] + unary[t + 1, j]
            if t + 2 < T:
                dot = (centres[t + 2, 0] - centres[t + 1, 0]) * offsets[j, 0]
                for d in range(1, D):
                    dot = dot + (centres[t + 2, d] - centres[t + 1, d]) * offsets[j, d]
                nxt_lin[j] = 2.0 * dot
                ct = ct - nxt_lin[j]
            W[t + 1, j] = nxt[j] + ct
        lin, nxt_lin = nxt_lin, lin
    last = 0
    for j in range(1, M):
        if W[T - 1, j] < W[T - 1, last]:
            last = j
    choice[T - 1] = last
    for t in range(T - 1, 0, -1):
        j = choice[t]
        arg = 0
        best = W[t - 1, 0] + G[0, j]
        for i in range(1, M):
            v = W[t - 1, i] + G[i, j]
            if v < best:
                best = v
                arg = i
        choice[t - 1] = arg
    return W[T - 1, last]


def _compiled_route():
    from ..jit import compiled

    return compiled(_route_kernel, np.zeros((3, 2)), np.zeros((2, 2)), np.zeros((3, 2)), np.zeros(3, dtype=np.intp))


def min_energy_route(
    centres: np.ndarray,
    offsets: np.ndarray,
    distortion: float = 0.0,
    blocked: np.ndarray | None = None,
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
    unary = np.empty((T, M))
    unary[:] = distortion * (offsets**2).sum(1)
    if blocked is not None:
        free = ~blocked
        free[~free.any(1)] = True
        unary[~free] = np.inf
    choice = np.empty(T, dtype=np.intp)
    kernel = _compiled_route()
    best = (_route_numpy if kernel is None else kernel)(centres, offsets, unary, choice)
    step = centres[1:] - centres[:-1]
    return choice, float(best + (step * step).sum())


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
