"""Path comparison metrics of the paper (§III.D): correlation coefficient R and MSD.

Multi-dimensional paths are compared as sequences of vectors: with waypoints m_i and m'_i
(shape (D,)) and their means m̄, m̄',

    R   = Σ (m_i − m̄)·(m'_i − m̄') / sqrt(Σ |m_i − m̄|² · Σ |m'_i − m̄'|²)     (eq. 1)
    MSD = (1/N) Σ |m_i − m'_i|²                                             (eq. 2)

where · is the dot product, so R is one number pooling all coordinates (not a per-axis mean) and
MSD is in squared path units.  1-D inputs (T,) are treated as (T, 1).  Paths of different
lengths are first resampled to the longer length by :func:`resample` (cubic spline), as in the
paper.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import InputError
from .validation import check_finite, check_int


def _as_path(a: Any, name: str) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"expected {name} as numbers, got {type(a).__name__}") from None
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] == 0:
        raise InputError(f"expected {name} of shape (T, D) or (T,) with T >= 1, got {arr.shape}")
    return check_finite(arr, name)


def resample(path: Any, n: int) -> np.ndarray:
    """Resample a path to ``n`` points by cubic spline interpolation over a uniform parameter.

    Parameters
    ----------
    path : array_like, shape (T, D) or (T,)
        Waypoints assumed equally spaced in time (the paper's constant Δt).
    n : int
        Number of output points, >= 1.

    Returns
    -------
    ndarray, shape (n, D)
        ``scipy.interpolate.CubicSpline`` (not-a-knot) through the T points at u = 0..1; the
        first and last points are kept exactly.  T = 1 repeats the point; T = 2 is linear.
    """
    from scipy.interpolate import CubicSpline

    arr = _as_path(path, "path")
    n = check_int(n, "n", minimum=1)
    T = arr.shape[0]
    if T == 1:
        return np.repeat(arr, n, axis=0)
    if n == T:
        return arr.copy()
    u = np.linspace(0.0, 1.0, T)
    out = CubicSpline(u, arr, axis=0)(np.linspace(0.0, 1.0, n))
    out[0], out[-1] = arr[0], arr[-1]
    return out


def _paired(a: Any, b: Any) -> tuple[np.ndarray, np.ndarray]:
    a, b = _as_path(a, "a"), _as_path(b, "b")
    if a.shape[1] != b.shape[1]:
        raise InputError(f"expected paths of the same dimension, got D = {a.shape[1]} and D = {b.shape[1]}")
    n = max(len(a), len(b))
    if len(a) != n:
        a = resample(a, n)
    if len(b) != n:
        b = resample(b, n)
    return a, b


def correlation(a: Any, b: Any) -> float:
    """Correlation coefficient R of two paths (eq. 1), in [-1, 1].

    Raises
    ------
    InputError
        Bad shapes, NaN/inf, different D, or a path with no spread (all points equal), for which
        R is undefined.
    """
    a, b = _paired(a, b)
    da, db = a - a.mean(0), b - b.mean(0)
    va, vb = float((da * da).sum()), float((db * db).sum())
    if va == 0.0 or vb == 0.0:
        which = "a" if va == 0.0 else "b"
        raise InputError(f"correlation is undefined: path {which} has no spread (all {len(a)} points equal)")
    return float((da * db).sum() / np.sqrt(va * vb))


def msd(a: Any, b: Any) -> float:
    """Mean squared difference of two paths (eq. 2), in squared path units."""
    a, b = _paired(a, b)
    return float(((a - b) ** 2).sum(1).mean())
