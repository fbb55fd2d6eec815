"""Minimum-energy route: Viterbi over time stamps, one candidate waypoint per stamp.

Candidates at stamp t are ``centres[t] + offsets[i]`` (the same offsets at every stamp).  The
route minimises

    E = Σ_t |q_{t+1} - q_t|²  +  distortion · Σ_t |q_t - centres[t]|²

(translational energy at constant Δt, plus an optional distortion term).  Candidates flagged in
``blocked`` are excluded.  Writing q = c + o, the step cost splits into
|Δc_t|² + 2Δc_t·(o_j - o_i) + |o_j - o_i|²: the last term is one (M, M) matrix for all stamps and
the linear terms are precomputed for all stamps at once, so each of the T-1 forward steps is one
(M, M) add, a row-wise min and a vector add (three small numpy calls);
the back-pointers are recovered afterwards for all stamps in one vectorised argmin — O(T·M²)
work with O(T) cheap Python steps.
:func:`min_energy_route_reference` is the slow, obvious version the tests compare against.
"""

from __future__ import annotations

import numpy as np


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
    T, M = centres.shape[0], offsets.shape[0]
    unary = np.broadcast_to(distortion * (offsets**2).sum(1), (T, M)).copy()
    if blocked is not None:
        free = ~blocked
        free[~free.any(1)] = True
        unary[~free] = np.inf
    step = np.diff(centres, axis=0)  # (T-1, D)
    lin = 2.0 * step @ offsets.T  # (T-1, M): + for the next candidate j, - for the previous i
    G = ((offsets[:, None, :] - offsets[None, :, :]) ** 2).sum(-1)  # (M, M), [i, j]
    # W[t] = V[t] - lin[t]: the cost-to-here with the outgoing linear term already applied, so
    # the forward step is W[t+1] = min_i (W[t][i] + G[i, :]) + c[t], c[t] = lin[t] + unary[t+1] - lin[t+1].
    c = lin + unary[1:]
    c[:-1] -= lin[1:]
    Gt = np.ascontiguousarray(G.T)  # [j, i]: reduce over the contiguous last axis
    reduce_min = np.minimum.reduce
    w = unary[0] - lin[0] if T > 1 else unary[0].copy()
    rows = [w]
    for ct in c:
        w = reduce_min(w + Gt, axis=1)
        w += ct
        rows.append(w)
    W = np.array(rows)
    # back-pointers for every stamp at once, from the same stored values (identical ties)
    back = (W[:-1, None, :] + Gt[None]).argmin(2) if T > 1 else np.empty((0, M), dtype=np.intp)  # [t, j]
    choice = np.empty(T, dtype=np.intp)
    choice[-1] = int(W[-1].argmin())
    energy = float(W[-1, choice[-1]] + (step**2).sum())
    for t in range(T - 1, 0, -1):
        choice[t - 1] = back[t - 1, choice[t]]
    return choice, energy


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
