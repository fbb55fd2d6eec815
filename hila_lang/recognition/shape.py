"""Similarity-invariant shape descriptions of a path: arc length, heading, Procrustes distance.

Why these (issue 26: recognition must not care where, how big, how turned or how fast a known
part was made):

- **Speed (time warping).**  Paths are re-sampled at equal steps of *arc length*
  (:func:`arc_resample`): how fast the hand moved, where it paused and how the speed varied
  inside a stroke leave no trace.  Times are kept only to map arc length back to samples.
- **Where and how turned.**  The search signal is the *heading* of the path, the direction of
  travel, unwrapped, as a function of arc length (:func:`heading`).  Translation does not change
  it; a turn adds a constant, which the search removes per window (the window's mean heading).
  In 3-D (robot frame, z up; a board is turned about the vertical) the signal is the heading of
  the horizontal motion plus the elevation of the travel direction.
- **How big.**  A shape drawn σ times bigger has the same heading curve stretched σ times in
  arc length: the search tries each library part at a geometric ladder of lengths
  (:mod:`.search`).
- **Verification.**  Each candidate window is compared with the library part by the
  *Procrustes distance* (:func:`procrustes_distance`): both re-sampled to the same number of
  points by arc length, centred, scaled to unit size and optimally rotated (Kabsch, no
  reflection); the distance is the RMS of what is left, 0 for the same shape, at most 1.  It
  uses every coordinate (full 3-D rotation), so it also checks what the heading signal folds away.

Curvature (turning angle per step) was the other invariant considered: it is rotation invariant
without the per-window mean, but it is the derivative of the heading, so tracking noise is
amplified, and a straight stretch gives ~0 whatever its direction; the heading is its integral
and degrades gracefully.
"""

from __future__ import annotations

import numpy as np

from ..osila.fallback import fit_similarity

#: smoothing of the raw samples before arc length is measured, samples (Gaussian sigma):
#: tracking noise on a paused hand would otherwise add arc length and random headings
SMOOTH_SAMPLES = 1.5


def smooth(path: np.ndarray, sigma: float = SMOOTH_SAMPLES) -> np.ndarray:
    """``path`` (T, D) low-passed along time with a Gaussian of ``sigma`` samples (ends held)."""
    if sigma <= 0 or len(path) < 3:
        return np.asarray(path, float)
    # lazy: loads scipy, which importing this module does not
    from scipy.ndimage import gaussian_filter1d

    return gaussian_filter1d(np.asarray(path, float), sigma, axis=0, mode="nearest")


def arc_length(path: np.ndarray) -> np.ndarray:
    """Cumulative arc length at every sample, shape (T,), starting at 0."""
    step = np.sqrt((np.diff(path, axis=0) ** 2).sum(1))
    return np.concatenate([[0.0], np.cumsum(step)])


def arc_resample(path: np.ndarray, n: int, s: np.ndarray | None = None,
                 lo: float | None = None, hi: float | None = None) -> np.ndarray:
    """``n`` points at equal arc-length steps from arc length ``lo`` to ``hi`` (default: whole path)."""
    s = arc_length(path) if s is None else s
    lo = s[0] if lo is None else lo
    hi = s[-1] if hi is None else hi
    u = np.linspace(lo, hi, n)
    keep = np.concatenate([[True], np.diff(s) > 0])  # a paused hand repeats arc length
    return np.column_stack([np.interp(u, s[keep], path[keep, d]) for d in range(path.shape[1])])


def heading(points: np.ndarray) -> np.ndarray:
    """Search signal of equally spaced points (n, D): (n - 1, C) with C = 1 (2-D) or 2 (3-D).

    Column 0 is the unwrapped heading of the horizontal (x, y) travel, radians; in 3-D column 1
    is the elevation of the travel direction above the x-y plane, radians.
    """
    d = np.diff(points, axis=0)
    head = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    if points.shape[1] == 2:
        return head[:, None]
    horizontal = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2)
    return np.column_stack([head, np.arctan2(d[:, 2], horizontal)])


def _unit(a: np.ndarray) -> np.ndarray:
    """Centred and scaled to unit Frobenius norm, over the last two axes."""
    a = a - a.mean(axis=-2, keepdims=True)
    norm = np.sqrt((a * a).sum(axis=(-2, -1), keepdims=True))
    return a / np.maximum(norm, 1e-12)


def procrustes_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Similarity-invariant distance between point sets ``a`` (..., n, D) and ``b`` (n, D).

    sqrt(1 - (Σ σ_i')²) where σ' are the singular values of the cross-covariance of the unit-size
    centred sets, the last one negated if the best orthogonal map is a reflection: the RMS
    residual after the best translation, scale and rotation, in [0, 1].  Broadcasts over
    leading axes of ``a``.
    """
    A, B = _unit(np.asarray(a, float)), _unit(np.asarray(b, float))
    m = np.swapaxes(A, -1, -2) @ B
    u, sv, vt = np.linalg.svd(m)
    sign = np.sign(np.linalg.det(u @ vt))
    sv = sv.copy()
    sv[..., -1] *= np.where(sign == 0, 1.0, sign)
    return np.sqrt(np.clip(1.0 - sv.sum(-1) ** 2, 0.0, 1.0))


#: DTW band of :func:`elastic_distance`, points of REFERENCE_POINTS (64): 1/8 of the part
ELASTIC_WINDOW = 8


def similarity_map(src: np.ndarray, dst: np.ndarray):
    """The least-squares similarity taking paired rows ``src`` to ``dst`` (osila.fallback.fit_similarity), as a function of rows."""
    scale, rot, shift = fit_similarity(src, dst, 2)
    return lambda x: scale * (np.asarray(x, float) @ rot.T) + shift


def elastic_distance(a: np.ndarray, b: np.ndarray, window: int = ELASTIC_WINDOW) -> float:
    """Procrustes distance after letting the correspondence stretch (dtaidistance's DTW).

    Two demonstrations of one shape differ in proportions: one loop drawn longer, one stroke
    shorter.  At equal arc-length steps their points then pair wrongly and the Procrustes
    distance (:func:`procrustes_distance`) grows although the shape is the same.  Here ``a``
    (n, D) is aligned to ``b`` (n, D) by similarity, the point pairing is re-chosen by DTW
    (``dtaidistance.dtw_ndim.warping_path``, band ``window``), the similarity re-fitted on the
    DTW pairs, twice; the distance is the RMS of the paired residuals on the unit-size scale of
    :func:`procrustes_distance`.  Measured on LASA's 14 development shapes (demonstration 1 of
    each against its other six, and against every demonstration of the other shapes): the same
    shape 0.053 median, 0.106 at most; another shape 0.123 at least (plain Procrustes: 0.214
    at most against 0.168 at least; they overlap).
    """
    # lazy: dtaidistance (the 'recognise' extra), which importing this module does not load
    from dtaidistance import dtw_ndim

    A, B = _unit(np.asarray(a, float)), _unit(np.asarray(b, float))
    A = similarity_map(A, B)(A)
    for last in (False, False, True):
        i, j = np.array(dtw_ndim.warping_path(np.ascontiguousarray(A), np.ascontiguousarray(B), window=window, use_c=True)).T
        if last:
            break
        A = similarity_map(A[i], B[j])(A)
    return float(np.sqrt(((A[i] - B[j]) ** 2).sum(1).mean() * len(B)))
