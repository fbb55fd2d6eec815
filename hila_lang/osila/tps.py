"""Feature distortion warping: a thin plate spline from template ICPs to task ICPs.

:func:`fit_warp` fits the map f with f(template ICP k) = task ICP k and returns a callable
:class:`Warp`.  Kernels are the biharmonic ones: U(r) = r² log r in 2-D and U(r) = r in 3-D, plus
an affine part.  ``smoothing`` = λ >= 0 adds λ·I to the kernel matrix (0 = exact interpolation).
The fit runs on template points centred and scaled to unit extent (for conditioning), so λ is
unit-free: about 0.01–1 gives a visibly smoother, approximating map.

Rules for awkward ICP sets (never a crash):

- Pairs whose template points lie within ``1e-6 ×`` the template points' extent of each other
  cannot all be interpolated (the TPS system would be singular): the LAST such pair given wins.
  Callers put the most specific binding last — a sub-template's "start" bound to where the hand
  is overrides a scene ICP at the same template point, and plan-adjustment pairs come after the
  ICPs.
- After merging, fewer than D+1 pairs, or template points that do not span D dimensions
  (collinear in 2-D, coplanar in 3-D: the smallest singular value of the centred points below
  ``1e-3 ×`` the largest), fall back to a similarity transform (>= 2 distinct points) or a
  translation (1 point).  The fallback is reported in :attr:`Warp.kind`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fallback import fit_similarity

MERGE_TOL = 1e-6
DEGENERATE_TOL = 1e-3


def kernel(r: np.ndarray, dim: int) -> np.ndarray:
    """Biharmonic radial kernel U(r): r² log r for ``dim`` = 2 (0 at r = 0), r for ``dim`` = 3."""
    if dim == 2:
        with np.errstate(divide="ignore", invalid="ignore"):
            out = r * r * np.log(r)
        return np.where(r > 0, out, 0.0)
    return r


def _dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise Euclidean distances, (N, D) x (M, D) -> (N, M)."""
    d2 = (a * a).sum(1)[:, None] + (b * b).sum(1)[None, :] - 2.0 * a @ b.T
    return np.sqrt(np.maximum(d2, 0.0))


@dataclass
class Warp:
    """A fitted map from template space to task space, shape (N, D) -> (N, D).

    Attributes
    ----------
    kind : str
        ``"tps"``, ``"similarity"`` or ``"translation"``.
    src : ndarray, shape (K', D)
        Template points actually used (after merging near-duplicates).
    dst : ndarray, shape (K', D)
        Their task points.
    weights : ndarray, shape (K', D)
        TPS kernel weights (zeros for the fallbacks).
    affine : ndarray, shape (D+1, D)
        ``[shift; A]`` so that the affine part is ``shift + x @ A``.
    """

    kind: str
    src: np.ndarray
    dst: np.ndarray
    weights: np.ndarray
    affine: np.ndarray

    def __call__(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        return self.affine[0] + points @ self.affine[1:]


def merge_pairs(src: np.ndarray, dst: np.ndarray, tol: float = MERGE_TOL) -> tuple[np.ndarray, np.ndarray]:
    """Drop pairs whose template point coincides (within ``tol ×`` extent) with a later pair's.

    Groups are formed greedily in input order (each pair joins the first earlier group whose
    first template point is within the tolerance); each group keeps its last pair.
    """
    extent = float(np.ptp(src, axis=0).max()) if len(src) > 1 else 0.0
    eps = tol * extent
    groups: list[list[int]] = []
    for i in range(len(src)):
        for g in groups:
            if np.linalg.norm(src[i] - src[g[0]]) <= eps:
                g.append(i)
                break
        else:
            groups.append([i])
    if len(groups) == len(src):
        return src, dst
    keep = [g[-1] for g in groups]
    return src[keep], dst[keep]


def affine_rank(src: np.ndarray, tol: float = DEGENERATE_TOL) -> int:
    """Number of dimensions the centred points span (singular values above ``tol ×`` the largest)."""
    if len(src) < 2:
        return 0
    s = np.linalg.svd(src - src.mean(0), compute_uv=False)
    if s[0] <= 0:
        return 0
    return int((s > tol * s[0]).sum())


def fit_warp(src: np.ndarray, dst: np.ndarray, smoothing: float = 0.0) -> Warp:
    """Fit the template-to-task map from paired points (validated arrays, shape (K, D), K >= 1).

    Parameters
    ----------
    src : ndarray, shape (K, D)
        Template ICPs.
    dst : ndarray, shape (K, D)
        Task ICPs paired by row.
    smoothing : float
        TPS regulariser λ >= 0 (0 = exact interpolation).

    Returns
    -------
    Warp
        TPS when K' >= D+1 non-degenerate pairs remain after merging, else a similarity or a
        translation.
    """
    src, dst = merge_pairs(src, dst)
    K, D = src.shape
    rank = affine_rank(src)
    zeros = np.zeros_like(src)
    if K == 1 or rank == 0:
        affine = np.vstack([dst.mean(0) - src.mean(0), np.eye(D)])
        return Warp("translation", src, dst, zeros, affine)
    if K < D + 1 or rank < D:
        scale, R, shift = fit_similarity(src, dst, rank)
        return Warp("similarity", src, dst, zeros, np.vstack([shift, scale * R.T]))
    # TPS: [[Kmat + λI, P], [Pᵀ, 0]] [w; a] = [dst; 0], P = [1, x].  Centre and scale the
    # template points for conditioning; the kernel is rescaled back below.
    mu = src.mean(0)
    sc = float(np.abs(src - mu).max())
    x = (src - mu) / sc
    Kmat = kernel(_dist(x, x), D)
    P = np.hstack([np.ones((K, 1)), x])
    A = np.zeros((K + D + 1, K + D + 1))
    A[:K, :K] = Kmat + smoothing * np.eye(K)
    A[:K, K:] = P
    A[K:, :K] = P.T
    rhs = np.zeros((K + D + 1, D))
    rhs[:K] = dst
    try:
        sol = np.linalg.solve(A, rhs)
    except np.linalg.LinAlgError:
        sol = np.linalg.lstsq(A, rhs, rcond=None)[0]
    w, a = sol[:K], sol[K:]
    # express in original coordinates: f(y) = a0 + ((y-mu)/sc) a1 + Σ w U(|y - s_k| / sc)
    affine = np.vstack([a[0] - (mu / sc) @ a[1:], a[1:] / sc])
    return _ScaledTPS("tps", src, dst, w, affine, mu=mu, scale=sc)


@dataclass
class _ScaledTPS(Warp):
    """A TPS, evaluated in the normalised frame it was fitted in (for conditioning)."""

    mu: np.ndarray = None  # type: ignore[assignment]
    scale: float = 1.0

    def __call__(self, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        out = self.affine[0] + points @ self.affine[1:]
        r = _dist(points, self.src) / self.scale
        return out + kernel(r, points.shape[1]) @ self.weights
