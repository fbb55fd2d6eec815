"""Feature distortion warping: a thin plate spline (or a safer map) from template ICPs to task ICPs.

:func:`fit_warp` fits the map f with f(template ICP k) = task ICP k and returns a callable
:class:`Warp`.  Kernels are the biharmonic ones: U(r) = r² log r in 2-D and U(r) = r in 3-D, plus
an affine part.  ``smoothing`` = λ >= 0 adds λ·I to the kernel matrix (0 = exact interpolation);
pairs flagged ``exact`` (pins) are interpolated exactly whatever λ is.  The fit runs on template
points centred and scaled to unit extent (for conditioning), so λ is unit-free: about 0.01–1
gives a visibly smoother, approximating map.

Which map (never a crash, never a blow-up)
------------------------------------------
- Pairs whose template points lie within ``1e-6 ×`` the template points' extent of each other
  cannot all be interpolated (the system would be singular): the LAST such pair given wins.
  Callers put the most specific binding last — a pin (a sub-template's start bound to where the
  hand is) overrides a scene ICP at the same template point, and plan-adjustment pairs come
  after the ICPs.
- One pair left: a translation.
- Without ``on`` (the bare warp, the ``tps`` control of ``hila eval``): the TPS whenever there
  are D+1 pairs spanning D dimensions (smallest singular value of the centred template points
  at least ``1e-3 ×`` the largest), else the similarity fallback below.
- With ``on`` (the path the map is for; what OSILA uses) the TPS must earn its place:

  1. at least D+2 pairs spanning D dimensions — with D+1 the TPS is an affine map fitted
     exactly, with no pair left to check it, and any ICP error becomes shear;
  2. it predicts each pair from the others at least as well as the fallback does (leave-one-out
     error: Rippa's closed form for the TPS, K refits for the fallback) — the data at hand says
     whether its ICPs carry a smooth deformation or a rigid placement plus noise.  A pair without
     which the others cannot determine a TPS (the hand above four exactly coplanar corners of a
     drawing surface: the system without it is singular) is left out of both means: no TPS can be fitted without it, so it says
     nothing about which map generalises, and counting it as an infinite error would hand the
     choice to the fallback however badly that predicts the other pairs;
  3. its amplification on the path is at most :data:`MAX_AMPLIFICATION` (below).

  Otherwise the **similarity** fallback: the least-squares similarity transform of the pairs
  (Umeyama) plus an exact interpolation of what it leaves at each pair, with the kernel
  φ(r) = r and a constant (always solvable for distinct points, in 2-D and 3-D, however they
  lie).  So every pair is still met exactly — a pinned start lands on the hand even when the
  scene ICPs are coplanar — and the correction between pairs stays as large as the residuals
  instead of being extrapolated by an ill-determined affine part.  ``Warp.kind`` says which.

``bench/warp.py`` measures this choice on synthetic pairs with a known true map (10 scenarios
of ICP noise and deformation, 2-D and 3-D): the mean error of the choice is the lowest of
"always TPS", "always fallback" and the choice in 8 of 10 scenarios and within 1 % of the
lowest in the other two; always using the TPS has the highest mean error in all 10 (its
blow-ups), always using the fallback loses where the true deformation is large.

Amplification
-------------
The TPS is linear in the task points: f(x) = Σ_k L_k(x) · task_k with cardinal functions L_k
(L_k = 1 at template ICP k, 0 at the others).  Its amplification on a path is the Lebesgue
constant Λ = max_t Σ_k |L_k(p_t)|: an error of δ in the task ICPs moves a mapped waypoint by at
most Λ·δ.  Λ >= 1; it is about 1–3 for ICPs spread around the path and grows without bound as
they become collinear (an affine part fitted on a sliver) or two of them nearly coincide while
bound far apart.  :data:`MAX_AMPLIFICATION` (6 in 2-D, 8 in 3-D) was chosen by measurement, not
on any evaluation data set: ``bench/warp.py`` maps synthetic templates by a known true map (a
random stretch/shear of about 10 % plus local bends of about 5 % of the extent) with ICPs
located to 1 % of the extent (OSILA's default threshold), and bins the error of both maps by Λ;
the TPS's median error passes the fallback's at Λ = 6 in 2-D and Λ = 8 in 3-D (4000 pairs each).

The small systems behind the choice run in a compiled kernel (:func:`_choice_kernel`, numba via
:mod:`hila_lang.jit`) for paths of at least :data:`hila_lang.jit.MIN_STAMPS` stamps, else in
numpy (:func:`_choice_numpy`); the tests hold them equal to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..jit import min_stamps
from .fallback import fit_similarity

MERGE_TOL = 1e-6
DEGENERATE_TOL = 1e-3
#: (A⁻¹)_kk of the normalised TPS system at most this: the system without pair k is singular
#: (rounding level; it is 1e-17 for the hand above four coplanar corners, about 1 otherwise)
SINGULAR_TOL = 1e-12
#: largest Lebesgue constant of a TPS on the mapped path before the similarity fallback is used,
#: per dimension D (see the module docstring; measured by ``bench/warp.py``)
MAX_AMPLIFICATION = {2: 6.0, 3: 8.0}


def kernel(r: np.ndarray, dim: int) -> np.ndarray:
    """Biharmonic radial kernel U(r): r² log r for ``dim`` = 2 (0 at r = 0), r for ``dim`` = 3."""
    if dim == 2:
        with np.errstate(divide="ignore", invalid="ignore"):
            out = r * r * np.log(r)
        return np.where(r > 0, out, 0.0)
    return r


def _dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise Euclidean distances, (N, D) x (M, D) -> (N, M), from coordinate differences (exact at 0)."""
    d2 = np.subtract.outer(a[:, 0], b[:, 0])
    d2 *= d2
    for k in range(1, a.shape[1]):
        t = np.subtract.outer(a[:, k], b[:, k])
        t *= t
        d2 += t
    return np.sqrt(d2, out=d2)


def _at_stamps(r: np.ndarray, tol: float) -> dict[int, int]:
    """Stamp -> pair index for pairs whose template point is a point of the path (r: (T, K) distances)."""
    hit = r <= tol
    if not hit.any():
        return {}
    t, k = np.nonzero(hit)
    return {int(a): int(b) for a, b in zip(t.tolist(), k.tolist())}


@dataclass
class Warp:
    """A fitted map from template space to task space, shape (N, D) -> (N, D).

    ``f(x) = shift + x @ A + Σ_k weights_k · φ(|x - src_k| / scale)``, with φ the TPS kernel
    (:func:`kernel`) for ``"tps"`` and φ(r) = r for the residual part of ``"similarity"``.

    Attributes
    ----------
    kind : str
        ``"tps"``, ``"similarity"`` or ``"translation"``.
    src : ndarray, shape (K', D)
        Template points actually used (after merging near-duplicates).
    dst : ndarray, shape (K', D)
        Their task points.
    weights : ndarray, shape (K', D)
        Kernel weights (zeros for a translation, or a similarity that fits exactly).
    affine : ndarray, shape (D+1, D)
        ``[shift; A]``.
    scale : float
        Unit of the kernel distances (the template points' extent).
    amplification : float or None
        Lebesgue constant of the TPS on the path it was checked on (None: not checked).
    mapped : ndarray, shape (T, D), or None
        The image of that path (``on`` of :func:`fit_warp`), computed with the fit.
    at : dict of int to int
        For that path: stamp -> index of the pair whose template point is that path point (within
        ``1e-6 ×`` the extent), e.g. a segment boundary or a sub-template's start.
    loo : float or None
        Leave-one-out error of the TPS at its own pairs (mean squared, task units²), when checked.
    """

    kind: str
    src: np.ndarray
    dst: np.ndarray
    weights: np.ndarray
    affine: np.ndarray
    scale: float = 1.0
    amplification: float | None = None
    mapped: np.ndarray | None = None
    loo: float | None = None
    at: dict = field(default_factory=dict)

    def __call__(self, points: np.ndarray) -> np.ndarray:
        return self._map(np.asarray(points, dtype=float))[0]

    def _map(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The image of ``points`` and their distances to the pairs' template points (unit: ``scale``)."""
        out = self.affine[0] + points @ self.affine[1:]
        r = _dist(points, self.src) / self.scale
        if self.weights.any():
            phi = kernel(r, points.shape[1]) if self.kind == "tps" else r
            out = out + phi @ self.weights
        return out, r

    def map_on(self, path: np.ndarray, tol: float) -> None:
        """Set :attr:`mapped` and :attr:`at` for ``path`` (template points within ``tol`` of a path point)."""
        self.mapped, r = self._map(path)
        self.at = _at_stamps(r, tol / self.scale)


def merge_pairs(
    src: np.ndarray, dst: np.ndarray, tol: float = MERGE_TOL, exact: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drop pairs whose template point coincides (within ``tol ×`` extent) with a later pair's.

    Groups are formed greedily in input order (each pair joins the first earlier group whose
    first template point is within the tolerance); each group keeps its last pair.  Returns
    ``(src, dst, exact)`` of the kept pairs (``exact`` all False when not given).
    """
    exact = np.zeros(len(src), bool) if exact is None else np.asarray(exact, bool)
    extent = float(np.ptp(src, axis=0).max()) if len(src) > 1 else 0.0
    close = _dist(src, src) <= tol * extent
    if close.sum() == len(src):  # only each point with itself: nothing to merge
        return src, dst, exact
    close = close.tolist()
    groups: list[list[int]] = []
    for i in range(len(src)):
        for g in groups:
            if close[i][g[0]]:
                g.append(i)
                break
        else:
            groups.append([i])
    if len(groups) == len(src):
        return src, dst, exact
    keep = [g[-1] for g in groups]
    return src[keep], dst[keep], exact[keep]


def affine_rank(src: np.ndarray, tol: float = DEGENERATE_TOL) -> int:
    """Number of dimensions the centred points span (singular values above ``tol ×`` the largest)."""
    if len(src) < 2:
        return 0
    a = src - src.sum(0) / len(src)
    cov = a.T @ a  # singular values of the centred points = square roots of its eigenvalues
    if cov.shape == (2, 2):
        half, gap = 0.5 * (cov[0, 0] + cov[1, 1]), np.hypot(0.5 * (cov[0, 0] - cov[1, 1]), cov[0, 1])
        eig = np.array([half + gap, half - gap])
    else:
        eig = np.linalg.eigvalsh(cov)[::-1]
    s = np.sqrt(np.maximum(eig, 0.0))
    if s[0] <= 0:
        return 0
    return int((s > tol * s[0]).sum())


def _solve(A: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.solve(A, rhs)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, rhs, rcond=None)[0]


def _tps_system(src: np.ndarray, ridge: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """(mu, sc, A) of the TPS system on the template points centred at mu and scaled by 1/sc.

    A = [[U(|x_i - x_j|) + diag(ridge), 1, x], [1ᵀ, 0, 0], [xᵀ, 0, 0]], shape (K + D + 1,) * 2.
    """
    K, D = src.shape
    mu = src.sum(0) / K
    sc = float(np.abs(src - mu).max())
    x = (src - mu) / sc
    A = np.zeros((K + D + 1, K + D + 1))
    A[:K, :K] = kernel(_dist(x, x), D) + np.diag(ridge)
    A[:K, K] = 1.0
    A[:K, K + 1:] = x
    A[K, :K] = 1.0
    A[K + 1:, :K] = x.T
    return mu, sc, A


def _tps_warp(src, dst, mu, sc, sol, **extra) -> Warp:
    """A TPS Warp from the solution [w; a] of the normalised system."""
    K = len(src)
    w, a = sol[:K], sol[K:]
    # f(y) = a0 + ((y-mu)/sc) a1 + Σ w U(|y - s_k| / sc)
    affine = np.vstack([a[0] - (mu / sc) @ a[1:], a[1:] / sc])
    return Warp("tps", src, dst, w, affine, sc, **extra)


def _tps(src: np.ndarray, dst: np.ndarray, ridge: np.ndarray) -> Warp:
    """The bare TPS through the pairs (ridge: (K,) diagonal regulariser)."""
    K, D = src.shape
    mu, sc, A = _tps_system(src, ridge)
    rhs = np.zeros((K + D + 1, D))
    rhs[:K] = dst
    return _tps_warp(src, dst, mu, sc, _solve(A, rhs))


def _similarity_parts(src, dst, ridge, rank) -> tuple[np.ndarray, np.ndarray]:
    """(lin (D + 1, D) = [shift; (scale R)ᵀ], w (K, D)): least-squares similarity plus the exact
    φ(r) = r interpolation of its residuals (φ on distances divided by the points' extent)."""
    K, D = src.shape
    scale, R, shift = fit_similarity(src, dst, rank)
    lin = np.vstack([shift, scale * R.T])
    resid = dst - (lin[0] + src @ lin[1:])
    w = np.zeros_like(src)
    if np.abs(resid).max() > 1e-12 * max(float(np.abs(dst).max()), 1.0):
        sc = float(np.abs(src - src.sum(0) / K).max())
        A = np.zeros((K + 1, K + 1))
        A[:K, :K] = _dist(src, src) / sc + np.diag(ridge)
        A[:K, K] = A[K, :K] = 1.0
        rhs = np.zeros((K + 1, D))
        rhs[:K] = resid
        sol = _solve(A, rhs)
        w = sol[:K]
        lin[0] += sol[K]
    return lin, w


def _similarity(src, dst, lin, w, amplification) -> Warp:
    K = len(src)
    return Warp("similarity", src, dst, w, lin, float(np.abs(src - src.sum(0) / K).max()), amplification)


def _choice_kernel(src, dst, ridge, card, lin, w, loo):  # pragma: no cover - compiled by numba (hila_lang.jit)
    """The small systems behind :func:`fit_warp`'s choice, as loops (numpy twin: :func:`_choice_numpy`).

    Fills ``card`` (K + D + 1, K) with A⁻¹[:, :K] of the TPS system on the normalised template
    points, ``lin`` (D + 1, D) and ``w`` (K, D) with the similarity fallback on all pairs, and
    ``loo`` (K,) with the fallback's leave-one-out squared error per pair.  Needs K >= D + 2
    points spanning D dimensions.
    """
    K, D = src.shape
    mu = np.zeros(D)
    for i in range(K):
        mu += src[i]
    mu /= K
    sc = 0.0
    for i in range(K):
        for d in range(D):
            sc = max(sc, abs(src[i, d] - mu[d]))
    # --- the TPS system: [[U(|x_i - x_j|) + ridge, 1, x], [1, 0, 0], [xᵀ, 0, 0]]
    n = K + D + 1
    A = np.zeros((n, n))
    for i in range(K):
        for j in range(K):
            r2 = 0.0
            for d in range(D):
                diff = (src[i, d] - mu[d]) / sc - (src[j, d] - mu[d]) / sc
                r2 += diff * diff
            r = np.sqrt(r2)
            if D == 2:
                A[i, j] = r * r * np.log(r) if r > 0 else 0.0
            else:
                A[i, j] = r
        A[i, i] += ridge[i]
        A[i, K] = 1.0
        A[K, i] = 1.0
        for d in range(D):
            A[i, K + 1 + d] = (src[i, d] - mu[d]) / sc
            A[K + 1 + d, i] = A[i, K + 1 + d]
    E = np.zeros((n, K))
    for i in range(K):
        E[i, i] = 1.0
    card[:, :] = np.linalg.solve(A, E)
    # --- the similarity fallback, fitted on all pairs (skip = -1) and without each pair k
    phi = np.empty((K, K))
    for i in range(K):
        for j in range(K):
            r2 = 0.0
            for d in range(D):
                diff = src[i, d] - src[j, d]
                r2 += diff * diff
            phi[i, j] = np.sqrt(r2) / sc
    for skip in range(-1, K):
        m = K if skip < 0 else K - 1
        rows = np.empty(m, dtype=np.int64)
        u = 0
        for i in range(K):
            if i != skip:
                rows[u] = i
                u += 1
        ms = np.zeros(D)
        md = np.zeros(D)
        for u in range(m):
            ms += src[rows[u]]
            md += dst[rows[u]]
        ms /= m
        md /= m
        sR = np.zeros((D, D))  # scale * R
        if D == 2:
            re = 0.0
            im = 0.0
            var = 0.0
            for u in range(m):
                i = rows[u]
                a0, a1 = src[i, 0] - ms[0], src[i, 1] - ms[1]
                b0, b1 = dst[i, 0] - md[0], dst[i, 1] - md[1]
                re += b0 * a0 + b1 * a1
                im += b1 * a0 - b0 * a1
                var += a0 * a0 + a1 * a1
            re /= var
            im /= var
            sR[0, 0], sR[0, 1], sR[1, 0], sR[1, 1] = re, -im, im, re
        else:
            cov = np.zeros((D, D))
            var = 0.0
            for u in range(m):
                i = rows[u]
                for r in range(D):
                    var += (src[i, r] - ms[r]) ** 2
                    for c in range(D):
                        cov[r, c] += (dst[i, r] - md[r]) * (src[i, c] - ms[c])
            U, S, Vt = np.linalg.svd(cov)
            if np.linalg.det(U @ Vt) < 0:
                U[:, D - 1] *= -1.0
                S[D - 1] *= -1.0
            sR = (S.sum() / var) * (U @ Vt)
        # exact interpolation of the residuals: [[phi + ridge, 1], [1, 0]] [w; c] = [resid; 0]
        B = np.zeros((m + 1, m + 1))
        R = np.zeros((m + 1, D))
        for u in range(m):
            i = rows[u]
            for v in range(m):
                B[u, v] = phi[i, rows[v]]
            B[u, u] += ridge[i] if skip < 0 else 0.0
            B[u, m] = 1.0
            B[m, u] = 1.0
            for d in range(D):
                pred = md[d]
                for c in range(D):
                    pred += sR[d, c] * (src[i, c] - ms[c])
                R[u, d] = dst[i, d] - pred
        sol = np.linalg.solve(B, R)
        if skip < 0:
            for d in range(D):
                shift = md[d] + sol[m, d]
                for c in range(D):
                    shift -= sR[d, c] * ms[c]
                    lin[1 + c, d] = sR[d, c]
                lin[0, d] = shift
            for u in range(m):
                for d in range(D):
                    w[rows[u], d] = sol[u, d]
        else:
            loo[skip] = 0.0
            for d in range(D):
                pred = md[d] + sol[m, d]
                for c in range(D):
                    pred += sR[d, c] * (src[skip, c] - ms[c])
                for u in range(m):
                    pred += phi[skip, rows[u]] * sol[u, d]
                loo[skip] += (pred - dst[skip, d]) ** 2


def _similarity_loo_numpy(src: np.ndarray, dst: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """All K leave-one-out fits of the similarity fallback at once: the squared error of each
    left-out pair, shape (K,) (see :func:`similarity_loo`)."""
    K, D = src.shape
    keep = ~np.eye(K, dtype=bool)
    # centroids without pair k, from the totals
    ms = (src.sum(0) - src) / (K - 1)  # (K, D)
    md = (dst.sum(0) - dst) / (K - 1)
    a = src[None, :, :] - ms[:, None, :]  # (K, K, D): all pairs about the k-th centroid
    ak = a * keep[:, :, None]  # pair k itself takes no part in fit k
    bk = (dst[None, :, :] - md[:, None, :]) * keep[:, :, None]
    if D == 2:  # as complex numbers the similarity is z -> c z, c = Σ b conj(a) / Σ |a|²
        za, zb = ak[..., 0] + 1j * ak[..., 1], bk[..., 0] + 1j * bk[..., 1]
        var = (za.real**2 + za.imag**2).sum(1)
        c = (zb * za.conj()).sum(1) / np.where(var > 0, var, 1.0)
        z = c[:, None] * (a[..., 0] + 1j * a[..., 1])
        pred_lin = np.stack([z.real, z.imag], axis=-1) + md[:, None, :]  # S_k(src_i)
    else:
        cov = np.matmul(bk.transpose(0, 2, 1), ak)  # (K, D, D)
        U, S, Vt = np.linalg.svd(cov)
        flip = np.linalg.det(np.matmul(U, Vt)) < 0
        U[flip, :, -1] *= -1.0
        S[flip, -1] *= -1.0
        var = (ak * ak).sum((1, 2))
        scale = S.sum(1) / np.where(var > 0, var, 1.0)
        pred_lin = scale[:, None, None] * np.matmul(a, np.matmul(U, Vt).transpose(0, 2, 1)) + md[:, None, :]
    resid = (dst[None] - pred_lin) * keep[:, :, None]  # (K, K, D), zero for the left-out pair
    A = np.zeros((K, K + 1, K + 1))
    A[:, :K, :K] = phi
    A[:, :K, K] = A[:, K, :K] = 1.0
    # pair k is taken out of system k: its row and column become the identity's
    idx = np.arange(K)
    A[idx, idx, :] = 0.0
    A[idx, :, idx] = 0.0
    A[idx, idx, idx] = 1.0
    rhs = np.zeros((K, K + 1, D))
    rhs[:, :K] = resid
    sol = np.linalg.solve(A, rhs)  # (K, K + 1, D); weight k of system k is 0
    pred = pred_lin[idx, idx] + np.einsum("kn,knd->kd", phi * keep, sol[:, :K]) + sol[:, K]
    return ((pred - dst) ** 2).sum(1)


def _choice_numpy(src, dst, ridge) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """:func:`_choice_kernel` in numpy: (card, lin, w, similarity leave-one-out errors (K,))."""
    K, D = src.shape
    _, _, A = _tps_system(src, ridge)
    rhs = np.zeros((K + D + 1, K))
    rhs[:K] = np.eye(K)
    card = np.linalg.solve(A, rhs)
    lin, w = _similarity_parts(src, dst, ridge, D)
    sc = float(np.abs(src - src.sum(0) / K).max())
    return card, lin, w, _similarity_loo_numpy(src, dst, _dist(src, src) / sc)


def _choice(src, dst, ridge, compiled_kernel: bool = True):
    """(card, lin, w, similarity LOO per pair (K,)) by the compiled kernel (if asked and
    available), else numpy; None if a system is singular."""
    from ..jit import compiled

    K, D = src.shape
    kernel = None if not compiled_kernel else compiled(_choice_kernel, _WARM[0], _WARM[1], np.zeros(4), np.zeros((7, 4)), np.zeros((3, 2)),
                      np.zeros((4, 2)), np.zeros(4))
    try:
        if kernel is None:
            return _choice_numpy(src, dst, ridge)
        card, lin, w, loo = np.empty((K + D + 1, K)), np.empty((D + 1, D)), np.zeros((K, D)), np.empty(K)
        kernel(np.ascontiguousarray(src), np.ascontiguousarray(dst), np.ascontiguousarray(ridge, dtype=float),
               card, lin, w, loo)
        return card, lin, w, loo
    except (np.linalg.LinAlgError, ZeroDivisionError):
        return None


_WARM = (np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.2]]),
         np.array([[0.1, 0.0], [1.0, 0.2], [0.0, 1.1], [1.3, 1.0]]))


def similarity_loo(src: np.ndarray, dst: np.ndarray) -> float:
    """Leave-one-out error of the similarity fallback (mean squared, task units²), K >= D + 2.

    Pair k is predicted by the fallback fitted on the other K - 1 pairs: the least-squares
    similarity (Umeyama; in 2-D its closed complex form) plus the exact φ(r) = r interpolation of
    its residuals.  ``inf`` if a fit is singular.
    """
    got = _choice(src, dst, np.zeros(len(src)))
    return float("inf") if got is None else float(got[3].mean())


def fit_warp(
    src: np.ndarray,
    dst: np.ndarray,
    smoothing: float = 0.0,
    *,
    exact: np.ndarray | None = None,
    on: np.ndarray | None = None,
    max_amplification: float | None = None,
) -> Warp:
    """Fit the template-to-task map from paired points (validated arrays, shape (K, D), K >= 1).

    Parameters
    ----------
    src : ndarray, shape (K, D)
        Template ICPs.
    dst : ndarray, shape (K, D)
        Task ICPs paired by row.
    smoothing : float
        Regulariser λ >= 0 (0 = exact interpolation).
    exact : ndarray of bool, shape (K,), optional
        Pairs interpolated exactly whatever ``smoothing`` is (pins).
    on : ndarray, shape (T, D), optional
        The template path the map will be applied to.  With it, the TPS is used only when it
        predicts each pair from the others better than the similarity fallback does and its
        amplification on ``on`` is at most ``max_amplification`` (module docstring), and the
        image of ``on`` is computed with the fit (:attr:`Warp.mapped`, :attr:`Warp.at`).
        Without it, a TPS is used whenever the points span D dimensions (the paper's bare warp).
    max_amplification : float, optional
        Default :data:`MAX_AMPLIFICATION` for the dimension.

    Returns
    -------
    Warp
    """
    src, dst, exact = merge_pairs(src, dst, exact=exact)
    K, D = src.shape
    rank = affine_rank(src)
    ridge = np.zeros(K) if exact is None or not smoothing else np.where(exact, 0.0, float(smoothing))
    if K == 1 or rank == 0:
        affine = np.vstack([dst.sum(0) / K - src.sum(0) / K, np.eye(D)])
        warp = Warp("translation", src, dst, np.zeros_like(src), affine)
    elif on is None and K >= D + 1 and rank == D:
        return _tps(src, dst, ridge)  # the bare warp
    else:
        got = (_choice(src, dst, ridge, len(on) >= min_stamps())
               if K >= D + 2 and rank == D and on is not None else None)
        amplification = None
        if got is not None:
            card, lin, w, sim_each = got
            sol = card @ dst
            diag = np.diagonal(card[:K])
            # the pairs a TPS can be fitted without (docstring, 2.): Rippa's error of pair k is
            # c_k / (A⁻¹)_kk, and (A⁻¹)_kk vanishes when the system without pair k is singular
            judged = np.abs(diag) > SINGULAR_TOL
            with np.errstate(divide="ignore", invalid="ignore"):
                tps_each = np.where(judged, ((sol[:K] / diag[:, None]) ** 2).sum(1), np.inf)
            tps_loo, sim_loo = ((float(tps_each[judged].mean()), float(sim_each[judged].mean())) if judged.any()
                                else (np.inf, 0.0))
            tie = (1e-9 * float(np.abs(dst - dst.sum(0) / K).max())) ** 2
            if tps_loo <= sim_loo + tie:
                # the TPS predicts left-out pairs at least as well: check its amplification on the path
                mu = src.sum(0) / K
                sc = float(np.abs(src - mu).max())
                y, x = (on - mu) / sc, (src - mu) / sc
                r_on = _dist(y, x)
                cardinal = kernel(r_on, D) @ card[:K] + card[K] + y @ card[K + 1:]  # (T, K): L_k(p_t)
                amplification = float(np.abs(cardinal).sum(1).max())
                if amplification <= (MAX_AMPLIFICATION[D] if max_amplification is None else max_amplification):
                    return _tps_warp(src, dst, mu, sc, sol, amplification=amplification, loo=tps_loo,
                                     mapped=cardinal @ dst, at=_at_stamps(r_on, _tol(on, src) / sc))
        else:
            lin, w = _similarity_parts(src, dst, ridge, rank)
        warp = _similarity(src, dst, lin, w, amplification)
    if on is not None:
        warp.map_on(on, _tol(on, src))
    return warp


def amplification(src: np.ndarray, on: np.ndarray) -> float:
    """Λ of the exact TPS through template points ``src`` (K, D) on the path ``on`` (T, D)."""
    K, D = src.shape
    mu, sc, A = _tps_system(src, np.zeros(K))
    rhs = np.zeros((K + D + 1, K))
    rhs[:K] = np.eye(K)
    card = _solve(A, rhs)
    y, x = (on - mu) / sc, (src - mu) / sc
    return float(np.abs(kernel(_dist(y, x), D) @ card[:K] + card[K] + y @ card[K + 1:]).sum(1).max())


def _tol(on: np.ndarray, src: np.ndarray) -> float:
    """:data:`MERGE_TOL` × the extent of a path and the template points."""
    rows = np.ascontiguousarray(np.vstack([on, src]).T)  # reduce along rows: much faster than axis 0
    return MERGE_TOL * float((rows.max(1) - rows.min(1)).max())
