"""The path warp: the template's own shape kept along the path, its pairs met exactly.

Between the rigid similarity fallback and the thin plate spline (:mod:`.tps`) sits a deformation
of the PATH itself, not of space: Laplacian trajectory editing (Nierhoff, Hirche & Nakamura 2016)
of the template as OSILA places it.  Written for the mapped template b_t (below) and the route's
offsets e_t = m_t - b_t from it,

    minimise  Σ_t |(L e)_t|²  +  μ Σ_t |e_t|²     subject to  e_{t_k} = q_k - b_{t_k}  (on-path pairs)

with L the path graph's Laplacian (row t: e_t minus the mean of its neighbours; at an end, minus
its one neighbour).  |L m - L b|² = |L e|², so the path m keeps the differential (Laplacian)
coordinates of b — its local shape — as well as the pairs allow, and every pair whose template
point is a point of the path (a sub-template's bound start and end, a boundary or via point, a
plan-adjustment repair) is met exactly at its own stamp.  The offsets are linear in the pairs'
residuals: ``m = b + M r`` with one (T, A) matrix per set of stamps (:func:`offsets_matrix`, a
banded solve, cached).

**Off-path pairs** (scene features the path does not pass through) bend space, as before: b is
the spatial warp they induce — the least-squares similarity of ALL pairs (the placement uses
everything) plus the fallback's exact φ(r) = r interpolation of what it leaves at the off-path
pairs, or the TPS through the off-path pairs where they alone earn it (:func:`.tps.fit_warp`'s
choice, on them).  So the similarity's leftover at an off-path pair is spread over space, its
leftover at an on-path pair along the path (the fallback spread it over space, so a correction
meant for one stroke leaked into every stroke drawn near it).

**The damping μ.**  A correction at one point of a movement says something about the movement
near it in time, and less further away.  ``μ = (ℓ (T - 1))⁻⁴`` makes the offsets a Gaussian-process
posterior mean whose prior (precision LᵀL + μ) has a correlation length of ℓ (T - 1) stamps; ℓ
is the template's OWN time scale (:func:`length_scale`: the maximum-marginal-likelihood RBF
length scale of its coordinates against time, the rule ``hila eval``'s ``gp`` baseline uses for
its offsets), so nothing is chosen on a task.  Measured on LASA's development shapes (never the
held-back ones; ``docs/osila.md``): the undamped edit (μ = 0) has mean Fréchet 2.505 / 2.166 /
1.816 at N = 2 / 3 / 4, fixed decays of 5 %, 10 %, 20 %, 40 % of the duration 2.48–2.50 /
2.16–2.24 / 1.81–1.98, the template's own ℓ 2.439 / 2.172 / 1.811.

**When.**  The path warp needs both ends of the path among the on-path pairs: it spreads a
correction between pairs along the path, and beyond the first or the last pair it could only
extrapolate the offsets, which on the stand-in (pairs inside the path, its ends free) cost
+67 % of Fréchet against the TPS (:func:`choose_warp` then keeps :func:`.tps.fit_warp`'s spatial
choice).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..core.jit import min_stamps
from .fallback import fit_similarity
from .tps import Warp, _dist, _solve, _tol, affine_rank, fit_warp, merge_pairs

#: the length scale is fitted on at most this many samples of the template, evenly spaced in
#: time (a fraction of the duration does not depend on the sampling; the cost grows as its cube)
FIT_SAMPLES = 50
#: the length scale's search: log-spaced grid over [1e-3, 10] (a fraction of the duration), 4 a
#: decade, refined by a parabola through the best grid point and its neighbours
LENGTH_GRID = np.logspace(-3.0, 1.0, 17)
#: the white-noise variance's grid, of the unit-scaled coordinates (1e-10 .. 1)
NOISE_GRID = np.logspace(-10.0, 0.0, 41)


def length_scale(path: np.ndarray) -> float:
    """The template's own time scale ℓ, a fraction of its duration.

    The maximum-marginal-likelihood length scale of a zero-mean Gaussian process with an RBF
    kernel (unit variance) plus white noise, fitted to the template's centred coordinates scaled
    to unit largest magnitude, against time in [0, 1], every coordinate an independent output
    with the same kernel (what scikit-learn's ``GaussianProcessRegressor`` fits with ``RBF +
    WhiteKernel``); at most :data:`FIT_SAMPLES` samples.  One eigendecomposition per grid length
    scale gives the likelihood at every noise level of the grid.  Cached per template.
    """
    path = np.ascontiguousarray(path, dtype=float)
    return _length_scale(path.shape, path.tobytes())


@lru_cache(maxsize=256)
def _length_scale(shape: tuple[int, int], data: bytes) -> float:
    path = np.frombuffer(data).reshape(shape)
    T = shape[0]
    if T < 3:
        return 1.0
    pick = np.unique(np.round(np.linspace(0, T - 1, min(T, FIT_SAMPLES))).astype(int))
    u = pick / (T - 1.0)
    y = path[pick] - path[pick].mean(0)
    top = float(np.abs(y).max())
    if top <= 0.0:
        return 1.0
    y = y / top
    d2 = (u[:, None] - u[None, :]) ** 2

    def best(ell: float) -> float:
        lam, U = np.linalg.eigh(np.exp(-0.5 * d2 / (ell * ell)))
        lam = np.maximum(lam, 0.0)
        proj = (U.T @ y) ** 2  # (n, D): the outputs in the kernel's eigenbasis
        var = lam[:, None] + NOISE_GRID[None, :]  # (n, noises)
        fit = (proj.sum(1)[:, None] / var).sum(0)
        logdet = np.log(var).sum(0) * y.shape[1]
        return float((-0.5 * (fit + logdet)).max())

    logs = np.log(LENGTH_GRID)
    ll = np.array([best(float(e)) for e in LENGTH_GRID])
    k = int(np.argmax(ll))
    if 0 < k < len(ll) - 1:  # a parabola through the best point and its neighbours (log ℓ)
        a, b, c = ll[k - 1], ll[k], ll[k + 1]
        den = a - 2.0 * b + c
        shift = 0.5 * (a - c) / den if den < 0 else 0.0
        return float(np.exp(logs[k] + shift * (logs[1] - logs[0])))
    return float(LENGTH_GRID[k])


def damping(path: np.ndarray) -> float:
    """μ = (ℓ (T - 1))⁻⁴ for the template ``path`` (module docstring)."""
    T = len(path)
    return (length_scale(path) * max(T - 1, 1)) ** -4.0


def offsets_matrix(T: int, stamps: tuple[int, ...], mu: float) -> np.ndarray:
    """(T, A): the offsets minimising |L e|² + μ|e|² with e fixed at ``stamps`` (A increasing,
    distinct), as a linear map of the fixed values: e = M r, M[stamps] = I.  Read only; cached."""
    return _offsets_matrix(int(T), tuple(int(s) for s in stamps), float(mu))


@lru_cache(maxsize=4096)
def _offsets_matrix(T: int, stamps: tuple[int, ...], mu: float) -> np.ndarray:
    # lazy: loads scipy, which importing this module does not
    from scipy.linalg import solveh_banded

    A = len(stamps)
    out = np.zeros((T, A))
    out[list(stamps), np.arange(A)] = 1.0
    fixed = np.zeros(T, bool)
    fixed[list(stamps)] = True
    free = np.flatnonzero(~fixed)
    if free.size == 0:
        out.flags.writeable = False
        return out
    N = _normal_bands(T, mu)  # LᵀL + μI as its five diagonals: N[k][t] = (LᵀL + μI)[t, t + k]
    # the free block, banded: free stamps in order, so two within 2 stamps of each other are
    # within 2 rows (1 row when a fixed stamp lies between them)
    pos = np.full(T, -1)
    pos[free] = np.arange(free.size)
    ab = np.zeros((3, free.size))  # upper form for solveh_banded: ab[2 - o, j] = A[j - o, j]
    ab[2] = N[0][free]
    for k in (1, 2):
        t = free[free + k < T]
        t = t[~fixed[t + k]]
        ab[2 - (pos[t + k] - pos[t]), pos[t + k]] = N[k][t]
    # right-hand side: -(LᵀL)_{free, fixed} r for r = the unit vectors
    rhs = np.zeros((free.size, A))
    for a, s in enumerate(stamps):
        for k in (-2, -1, 1, 2):
            t = s + k
            if 0 <= t < T and not fixed[t]:
                rhs[pos[t], a] -= N[abs(k)][min(s, t)]
    out[free] = solveh_banded(ab, rhs, lower=False, check_finite=False)
    out.flags.writeable = False
    return out


@lru_cache(maxsize=64)
def _normal_bands(T: int, mu: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The diagonals 0, 1, 2 of LᵀL + μI for the path graph's Laplacian L (T stamps)."""
    L = np.zeros((T, 3))  # row t: coefficients of e_{t-1}, e_t, e_{t+1}
    L[1:-1] = (-0.5, 1.0, -0.5)
    if T >= 2:
        L[0] = (0.0, 1.0, -1.0)
        L[-1] = (-1.0, 1.0, 0.0)
    else:
        L[0] = (0.0, 0.0, 0.0)
    d0, d1, d2 = np.zeros(T), np.zeros(T), np.zeros(T)
    # (LᵀL)[i, j] = Σ_t L[t, i] L[t, j]; row t touches columns t-1, t, t+1
    for a in range(3):
        for b in range(a, 3):
            i = np.arange(T) + a - 1
            j = np.arange(T) + b - 1
            ok = (i >= 0) & (j < T) & (i < T) & (j >= 0)
            v = L[ok, a] * L[ok, b]
            gap = b - a
            if gap == 0:
                np.add.at(d0, i[ok], v)
            elif gap == 1:
                np.add.at(d1, i[ok], v)
            else:
                np.add.at(d2, i[ok], v)
    d0 += mu
    return d0, d1, d2


def choose_warp(src: np.ndarray, dst: np.ndarray, smoothing: float = 0.0, *, exact: np.ndarray | None = None,
                on: np.ndarray | None = None, max_amplification: float | None = None, refits=None,
                along: bool = True, precision: float | None = None) -> Warp:
    """OSILA's map of the template: the path warp (:func:`fit_path`) where the pairs hold both ends
    of the path ``on`` (:func:`anchored`) and ``along`` allows it, else the spatial choice of
    :func:`.tps.fit_warp` (the same arguments)."""
    if on is not None and along and len(src) >= 2 and len(on) >= 3:
        # the compiled distances only for a long path, as fit_warp: at K = 4-6 on a 25-point path numba's
        # import and cache load (0.46 s, once a process) bought ~5 us a call (bit for bit the same)
        merged, to, flags = merge_pairs(src, dst, exact=exact, fast=len(on) >= min_stamps())
        if anchored(on, merged):
            return fit_path(on, merged, to, flags, smoothing, max_amplification=max_amplification,
                            precision=precision)
    return fit_warp(src, dst, smoothing, exact=exact, on=on, max_amplification=max_amplification, refits=refits,
                    precision=precision)


def anchored(on: np.ndarray, src: np.ndarray) -> bool:
    """True when the first and the last point of the path ``on`` (T, D) are both among the
    template points ``src`` (K, D) (within :data:`.tps.MERGE_TOL` of the extent): the path warp
    applies (module docstring, When).  O(K)."""
    ends = on.take([0, len(on) - 1], axis=0)  # on[[0, -1]] (take: a fraction of fancy indexing's cost)
    return bool((_dist(ends, src).min(1) <= _tol(on, src)).all())


def fit_path(on: np.ndarray, src: np.ndarray, dst: np.ndarray, exact: np.ndarray | None, smoothing: float = 0.0,
             *, max_amplification: float | None = None, precision: float | None = None):
    """The path warp of ``on`` (T, D) through merged pairs ``src`` -> ``dst`` (K, D) (module
    docstring): a :class:`.tps.Warp` of kind ``"path"`` with :attr:`~.tps.Warp.mapped` the bent
    path, :attr:`~.tps.Warp.at` the on-path pairs' stamps and :attr:`~.tps.Warp.base` the spatial
    map of the off-path pairs.  ``exact``, ``smoothing``: as :func:`.tps.fit_warp` (for the off-path
    pairs; on-path pairs are always met exactly)."""
    T, D = on.shape
    K = len(src)
    r = _dist(src, on)
    near = r.argmin(1)
    hit = r[np.arange(K), near] <= _tol(on, src)
    base = _base(on, src, dst, ~hit, exact, smoothing, max_amplification, precision)
    mapped = base(on)
    at = {int(near[k]): int(k) for k in np.flatnonzero(hit)}  # a later pair wins a shared stamp
    stamps = sorted(at)
    rows = [at[t] for t in stamps]
    M = offsets_matrix(T, tuple(stamps), damping(on))
    mapped = mapped + M @ (dst[rows] - mapped[stamps])
    mapped[stamps] = dst[rows]  # met exactly (the product meets them to rounding)
    return Warp("path", src, dst, np.zeros_like(src), base.affine, base.scale, base.amplification, mapped,
                at=at, base=base)


def _base(on, src, dst, off, exact, smoothing, max_amplification, precision):
    """The spatial map the off-path pairs induce (module docstring): the TPS through them where
    they alone earn it (:func:`.tps.fit_warp`'s choice, on at least D + 2 of them), else the
    least-squares similarity of ALL pairs plus the exact φ(r) = r interpolation (with a constant)
    of its residuals at the off-path pairs."""
    K, D = src.shape
    m = int(off.sum())
    if m >= D + 2 and affine_rank(src[off]) == D:
        spatial = fit_warp(src[off], dst[off], smoothing, exact=None if exact is None else exact[off], on=on,
                           max_amplification=max_amplification, precision=precision)
        if spatial.kind == "tps":
            return spatial
    rank = affine_rank(src)
    if rank == 0:
        scale, R, shift = 1.0, np.eye(D), dst.mean(0) - src.mean(0)
    else:
        scale, R, shift = fit_similarity(src, dst, rank)
    lin = np.vstack([shift, scale * R.T])
    so, do = src[off], dst[off]
    resid = do - (lin[0] + so @ lin[1:])
    weights = np.zeros((m, D))
    sc = 1.0
    if m == 1:
        lin[0] += resid[0]
    elif m >= 2:
        sc = float(np.abs(so - so.mean(0)).max()) or 1.0
        A = np.zeros((m + 1, m + 1))
        A[:m, :m] = _dist(so, so) / sc
        if smoothing:
            A[:m, :m] += np.diag(np.where(np.zeros(m, bool) if exact is None else exact[off], 0.0, float(smoothing)))
        A[:m, m] = A[m, :m] = 1.0
        rhs = np.zeros((m + 1, D))
        rhs[:m] = resid
        sol = _solve(A, rhs)
        weights, lin[0] = sol[:m], lin[0] + sol[m]
    return Warp("similarity", so, do, weights, lin, sc)
