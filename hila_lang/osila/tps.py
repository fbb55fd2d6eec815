"""Feature distortion warping: a thin plate spline from template ICPs to task ICPs.

:func:`fit_warp` fits the map f with f(template ICP k) = task ICP k and returns a callable
:class:`Warp`.  Kernels are the biharmonic ones: U(r) = r² log r in 2-D and U(r) = r in 3-D, plus
an affine part.  ``smoothing`` = λ >= 0 adds λ·I to the kernel matrix (0 = exact interpolation);
pairs flagged ``exact`` (pins) are interpolated exactly whatever λ is.  The fit runs on template
points centred and scaled to unit extent (for conditioning), so λ is unit-free: about 0.01–1
gives a visibly smoother, approximating map.

Rules for awkward ICP sets (never a crash, never a blow-up):

- Pairs whose template points lie within ``1e-6 ×`` the template points' extent of each other
  cannot all be interpolated (the system would be singular): the LAST such pair given wins.
  Callers put the most specific binding last — a pin (a sub-template's start bound to where the
  hand is) overrides a scene ICP at the same template point, and plan-adjustment pairs come
  after the ICPs.
- One pair left: a translation.
- Fewer than D+1 pairs, template points that do not span D dimensions (collinear in 2-D,
  coplanar in 3-D: smallest singular value of the centred points below ``1e-3 ×`` the largest),
  or — when the fit is given the path it will map (``on``) — a TPS whose *amplification* on that
  path exceeds :data:`MAX_AMPLIFICATION`: the **similarity** fallback.  It is the least-squares
  similarity transform of the pairs (Umeyama) plus an exact interpolation of what the similarity
  leaves at each pair, with the kernel φ(r) = r and a constant (always solvable for distinct
  points, in 2-D and 3-D, however the points lie).  So every pair is still met exactly — a
  pinned start lands on the hand even when the scene ICPs are coplanar — and the correction
  between the pairs stays as large as the residuals themselves instead of being extrapolated by
  an ill-determined affine part.  ``Warp.kind`` says which map was used.

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fallback import fit_similarity

MERGE_TOL = 1e-6
DEGENERATE_TOL = 1e-3
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
    """Pairwise Euclidean distances, (N, D) x (M, D) -> (N, M) (about ``b``'s centroid, for precision)."""
    c = b.mean(0)
    a, b = a - c, b - c
    d2 = (a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2.0 * a @ b.T
    return np.sqrt(np.maximum(d2, 0.0))


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
    """

    kind: str
    src: np.ndarray
    dst: np.ndarray
    weights: np.ndarray
    affine: np.ndarray
    scale: float = 1.0
    amplification: float | None = None
    mapped: np.ndarray | None = None

    def __call__(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        out = self.affine[0] + points @ self.affine[1:]
        if self.weights.any():
            r = _dist(points, self.src) / self.scale
            phi = kernel(r, points.shape[1]) if self.kind == "tps" else r
            out = out + phi @ self.weights
        return out


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
    close = (np.sqrt(((src[:, None, :] - src[None, :, :]) ** 2).sum(-1)) <= tol * extent).tolist()
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
    s = np.linalg.svd(src - src.mean(0), compute_uv=False)
    if s[0] <= 0:
        return 0
    return int((s > tol * s[0]).sum())


def _solve(A: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    try:
        return np.linalg.solve(A, rhs)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, rhs, rcond=None)[0]


def _tps(src, dst, ridge, on) -> Warp:
    """The TPS through the pairs (ridge: (K,) diagonal regulariser); amplification on ``on``."""
    K, D = src.shape
    # [[Kmat + diag(ridge), P], [Pᵀ, 0]] [w; a] = [dst; 0], P = [1, x], on template points
    # centred and scaled for conditioning; the affine part is expressed back below.
    mu = src.mean(0)
    sc = float(np.abs(src - mu).max())
    x = (src - mu) / sc
    A = np.zeros((K + D + 1, K + D + 1))
    A[:K, :K] = kernel(_dist(x, x), D) + np.diag(ridge)
    A[:K, K] = 1.0
    A[:K, K + 1:] = x
    A[K, :K] = 1.0
    A[K + 1:, :K] = x.T
    amplification = None
    if on is None:
        rhs = np.zeros((K + D + 1, D))
        rhs[:K] = dst
        sol = _solve(A, rhs)
    else:
        # cardinal functions: coefficients of every unit task vector, then Λ on the path
        rhs = np.zeros((K + D + 1, K))
        rhs[:K] = np.eye(K)
        card = _solve(A, rhs)  # (K + D + 1, K)
        y = (on - mu) / sc
        cardinal = kernel(_dist(y, x), D) @ card[:K] + card[K] + y @ card[K + 1:]  # (T, K): L_k(p_t)
        amplification = float(np.abs(cardinal).sum(1).max())
        sol = card @ dst
    w, a = sol[:K], sol[K:]
    # f(y) = a0 + ((y-mu)/sc) a1 + Σ w U(|y - s_k| / sc)
    affine = np.vstack([a[0] - (mu / sc) @ a[1:], a[1:] / sc])
    mapped = None if on is None else cardinal @ dst
    return Warp("tps", src, dst, w, affine, sc, amplification, mapped)


def _similarity(src, dst, ridge, rank, amplification) -> Warp:
    """Least-squares similarity plus an exact φ(r) = r interpolation of its residuals."""
    K, D = src.shape
    scale, R, shift = fit_similarity(src, dst, rank)
    lin = np.vstack([shift, scale * R.T])
    resid = dst - (lin[0] + src @ lin[1:])
    sc = float(np.abs(src - src.mean(0)).max())
    w = np.zeros_like(src)
    if np.abs(resid).max() > 1e-12 * max(float(np.abs(dst).max()), 1.0):
        A = np.zeros((K + 1, K + 1))
        A[:K, :K] = _dist(src, src) / sc + np.diag(ridge)
        A[:K, K] = A[K, :K] = 1.0
        rhs = np.zeros((K + 1, D))
        rhs[:K] = resid
        sol = _solve(A, rhs)
        w = sol[:K]
        lin = lin.copy()
        lin[0] += sol[K]
    return Warp("similarity", src, dst, w, lin, sc, amplification)


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
        The template path the map will be applied to: the TPS's amplification is checked on it
        and the similarity fallback used beyond ``max_amplification``.  Without it, a TPS is
        used whenever the points span D dimensions (the bare warp of the paper).
    max_amplification : float, optional
        See the module docstring; default :data:`MAX_AMPLIFICATION` for the dimension.

    Returns
    -------
    Warp
    """
    src, dst, exact = merge_pairs(src, dst, exact=exact)
    K, D = src.shape
    rank = affine_rank(src)
    if K == 1 or rank == 0:
        affine = np.vstack([dst.mean(0) - src.mean(0), np.eye(D)])
        warp = Warp("translation", src, dst, np.zeros_like(src), affine)
        warp.mapped = None if on is None else warp(on)
        return warp
    ridge = np.where(exact, 0.0, float(smoothing))
    amplification = None
    if max_amplification is None:
        max_amplification = MAX_AMPLIFICATION[D]
    if K >= D + 1 and rank == D:
        warp = _tps(src, dst, ridge, on)
        if warp.amplification is None or warp.amplification <= max_amplification:
            return warp
        amplification = warp.amplification
    warp = _similarity(src, dst, ridge, rank, amplification)
    if on is not None:
        warp.mapped = warp(on)
    return warp
