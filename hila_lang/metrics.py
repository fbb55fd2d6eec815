"""Path comparison metrics: the paper's R and MSD (§III.D), and shape metrics beyond them.

Multi-dimensional paths are compared as sequences of vectors: with waypoints m_i and m'_i
(shape (D,)) and their means m̄, m̄',

    R   = Σ (m_i − m̄)·(m'_i − m̄') / sqrt(Σ |m_i − m̄|² · Σ |m'_i − m̄'|²)     (eq. 1)
    MSD = (1/N) Σ |m_i − m'_i|²                                             (eq. 2)

where · is the dot product, so R is one number pooling all coordinates (not a per-axis mean) and
MSD is in squared path units.  Pooled R is dominated by the path's large overall motion (two
reaches that both go left to right correlate well whatever their shape), so these are reported
beside it, in the data's own units:

- :func:`axis_correlation` — R of each coordinate on its own (numpy);
- :func:`frechet` — the discrete Fréchet distance (Eiter & Mannila 1994): the largest gap when
  both paths are walked forward, neither going back;
- :func:`dtw` — dynamic time warping: the accumulated Euclidean distance along the best monotone
  alignment (the definition of ``similaritymeasures.dtw``), divided by the number of samples N,
  so it reads as an average gap in path units;
- :func:`endpoint_error` — the distance between the last points.

Fréchet and DTW are dynamic programmes over all N × M point pairs; ``similaritymeasures``
computes them with Python loops (about 7 ms for 100 × 100 points here, too slow for the tens of
thousands of pairs of ``hila eval``), so they are computed by a compiled kernel
(:mod:`hila_lang.core.jit`, numba) or, without numba, by numpy along anti-diagonals; the tests check
both against ``similaritymeasures``.  Distances between points come from
``scipy.spatial.distance.cdist``.

Every score ``hila eval`` reports is registered once, by name, with its kind (a correlation, higher
is better, or a distance, lower is better), whether it is time-free, its unit and its title
(:data:`METRICS`, :func:`register`); the evaluation's tables, tests, files and plots read the
registry, so a new metric is one registration here.

1-D inputs (T,) are treated as (T, 1).  Paths of different lengths are first resampled to the
longer length by :func:`resample` (cubic spline), as in the paper; :func:`resample_in_time` resamples
a timed path at a rate (every demonstration in hila is at 20 Hz).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Callable

import numpy as np

from .core.errors import InputError
from .core.jit import compiled
from .core.validation import check_finite, check_int


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
        The not-a-knot cubic spline (``scipy.interpolate.CubicSpline``'s default, the same
        numbers to rounding: :func:`_spline`) through the T points at u = 0..1; the first and
        last points are kept exactly.  T = 1 repeats the point; T = 2 is linear, T = 3 the
        parabola.  The spline is linear in the points: for T × n up to :data:`MATRIX_LIMIT` it
        is applied as a cached (n, T) matrix (the same numbers to rounding, without solving per
        call — ``hila eval`` resamples thousands of paths of a few dozen lengths).
    """
    arr = _as_path(path, "path")
    n = check_int(n, "n", minimum=1)
    T = arr.shape[0]
    if T == 1:
        return np.repeat(arr, n, axis=0)
    if n == T:
        return arr.copy()
    if T * n <= MATRIX_LIMIT:
        out = _resampling_matrix(T, n) @ arr
    else:
        out = _spline(arr, n)
    out[0], out[-1] = arr[0], arr[-1]
    return out


def _spline(y: np.ndarray, n: int) -> np.ndarray:
    """The not-a-knot cubic spline through ``y`` (T, D) at T equally spaced knots on 0..1,
    evaluated at ``n`` equally spaced points (n, D).  Without ``scipy.interpolate``: a game scores
    its marks with it, and importing that (it brings ``scipy.optimize``) cost a game 0.1 s.

    With equal spacing h the second derivatives M solve M[i-1] + 4 M[i] + M[i+1] = 6 Δ²y[i] / h²
    inside; not-a-knot (the third derivative continuous at the second and the last-but-one knot)
    is M[0] - 2 M[1] + M[2] = 0 and its mirror, which turn the first and last of those rows into
    6 M[1] = 6 Δ²y[1] / h² and 6 M[T-2] = 6 Δ²y[T-2] / h²: a tridiagonal system (LAPACK's banded
    solver, through ``scipy.linalg``, which the k-d trees have loaded already)."""
    T = len(y)
    h = 1.0 / (T - 1)
    if T == 2:
        m = np.zeros_like(y)
    elif T == 3:  # one interval's worth of freedom: the parabola (constant second derivative)
        m = np.repeat(((y[0] - 2.0 * y[1] + y[2]) / h ** 2)[None, :], 3, axis=0)
    else:
        # lazy: loads scipy, which importing this module does not
        from scipy.linalg import solve_banded

        k = T - 2
        bands = np.empty((3, k))
        bands[0], bands[1], bands[2] = 1.0, 4.0, 1.0  # above the diagonal, on it, below it
        bands[1, [0, -1]] = 6.0
        bands[0, 1] = bands[2, -2] = 0.0  # row 0's M[2] and row k-1's M[k-3]: gone with not-a-knot
        inner = solve_banded((1, 1), bands, 6.0 * (y[:-2] - 2.0 * y[1:-1] + y[2:]) / h ** 2)
        m = np.empty_like(y)
        m[1:-1] = inner
        m[0] = 2.0 * m[1] - m[2]
        m[-1] = 2.0 * m[-2] - m[-3]
    x = np.linspace(0.0, 1.0, n) / h
    k = np.minimum(np.floor(x).astype(int), T - 2)
    t = (x - k)[:, None]
    s = 1.0 - t
    return s * y[k] + t * y[k + 1] + (h * h / 6.0) * ((s ** 3 - s) * m[k] + (t ** 3 - t) * m[k + 1])


#: paths with T × n at most this resample through a cached matrix (:func:`_resampling_matrix`):
#: 200 × 200 samples (LASA's paths have 40-160, the stand-in's 32-64), 320 kB a matrix, so the
#: cache of 512 holds at most 160 MB (it held up to 8 GB: 4096 matrices of 250,000)
MATRIX_LIMIT = 40_000


def resample_in_time(t: np.ndarray, pos: np.ndarray, rate: float) -> np.ndarray:
    """Positions (T, D) sampled at ``t`` (T,), linearly re-sampled at ``rate`` Hz from t[0] to t[-1]."""
    n = max(int(round((t[-1] - t[0]) * rate)) + 1, 2)
    u = np.linspace(t[0], t[-1], n)
    return np.column_stack([np.interp(u, t, pos[:, d]) for d in range(pos.shape[1])])


@lru_cache(maxsize=512)
def _resampling_matrix(T: int, n: int) -> np.ndarray:
    """The (n, T) matrix of :func:`resample`: the spline is linear in the points, so its columns
    are the splines through the unit vectors (built once per pair of lengths, then a product)."""
    out = _spline(np.eye(T), n)
    out.flags.writeable = False
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
    return _correlation(*_paired(a, b))


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    da, db = a - a.mean(0), b - b.mean(0)
    va, vb = float((da * da).sum()), float((db * db).sum())
    if va == 0.0 or vb == 0.0:
        which = "a" if va == 0.0 else "b"
        raise InputError(f"correlation is undefined: path {which} has no spread (all {len(a)} points equal)")
    return float((da * db).sum() / np.sqrt(va * vb))


def msd(a: Any, b: Any) -> float:
    """Mean squared difference of two paths (eq. 2), in squared path units."""
    return _msd(*_paired(a, b))


def _msd(a: np.ndarray, b: np.ndarray) -> float:
    return float(((a - b) ** 2).sum(1).mean())


def axis_correlation(a: Any, b: Any) -> np.ndarray:
    """R (eq. 1) of each coordinate separately, shape (D,); NaN for a coordinate with no spread."""
    return _axis_correlation(*_paired(a, b))


def _axis_correlation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    da, db = a - a.mean(0), b - b.mean(0)
    den = np.sqrt((da * da).sum(0) * (db * db).sum(0))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, (da * db).sum(0) / np.where(den > 0, den, 1.0), np.nan)


def endpoint_error(a: Any, b: Any) -> float:
    """Distance between the last points of two paths (path units)."""
    a, b = _as_path(a, "a"), _as_path(b, "b")
    if a.shape[1] != b.shape[1]:
        raise InputError(f"expected paths of the same dimension, got D = {a.shape[1]} and D = {b.shape[1]}")
    return float(np.linalg.norm(a[-1] - b[-1]))


def _costs(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # lazy: loads scipy, which importing this module does not
    from scipy.spatial.distance import cdist

    return np.ascontiguousarray(cdist(a, b))


def _frechet_kernel(c):  # pragma: no cover - compiled by numba (hila_lang.core.jit)
    n, m = c.shape
    row = np.empty(m)
    row[0] = c[0, 0]
    for j in range(1, m):
        row[j] = max(row[j - 1], c[0, j])
    for i in range(1, n):
        diag = row[0]
        row[0] = max(row[0], c[i, 0])
        for j in range(1, m):
            up = row[j]
            best = min(up, row[j - 1], diag)
            row[j] = max(best, c[i, j])
            diag = up
    return row[m - 1]


def _dtw_kernel(c):  # pragma: no cover - compiled by numba (hila_lang.core.jit)
    n, m = c.shape
    row = np.empty(m)
    row[0] = c[0, 0]
    for j in range(1, m):
        row[j] = row[j - 1] + c[0, j]
    for i in range(1, n):
        diag = row[0]
        row[0] = row[0] + c[i, 0]
        for j in range(1, m):
            up = row[j]
            row[j] = min(up, row[j - 1], diag) + c[i, j]
            diag = up
    return row[m - 1]


def _diagonals(c: np.ndarray, combine: str) -> float:
    """The Fréchet (``"max"``) or DTW (``"sum"``) programme in numpy, one anti-diagonal at a time."""
    n, m = c.shape
    inf = np.inf
    acc = np.full((n, m), inf)
    acc[0, 0] = c[0, 0]
    for k in range(1, n + m - 1):
        i = np.arange(max(0, k - m + 1), min(n, k + 1))
        j = k - i
        up = np.where(i > 0, acc[np.maximum(i - 1, 0), j], inf)
        left = np.where(j > 0, acc[i, np.maximum(j - 1, 0)], inf)
        diag = np.where((i > 0) & (j > 0), acc[np.maximum(i - 1, 0), np.maximum(j - 1, 0)], inf)
        best = np.minimum(np.minimum(up, left), diag)
        acc[i, j] = np.maximum(best, c[i, j]) if combine == "max" else best + c[i, j]
    return float(acc[-1, -1])


def _programme(kernel, combine: str, a: Any, b: Any) -> float:
    a, b = _as_path(a, "a"), _as_path(b, "b")
    if a.shape[1] != b.shape[1]:
        raise InputError(f"expected paths of the same dimension, got D = {a.shape[1]} and D = {b.shape[1]}")
    return _run(kernel, combine, _costs(a, b))


def _run(kernel, combine: str, c: np.ndarray) -> float:
    fast = compiled(kernel, np.zeros((2, 3)))
    return float(fast(c)) if fast is not None else _diagonals(c, combine)


def frechet(a: Any, b: Any) -> float:
    """Discrete Fréchet distance between two paths (T, D) and (S, D), in path units.

    No resampling: every point of both paths is used as given.
    """
    return _programme(_frechet_kernel, "max", a, b)


def dtw(a: Any, b: Any) -> float:
    """DTW distance per sample: the accumulated distance of the best alignment / max(T, S), in path units."""
    a_, b_ = _as_path(a, "a"), _as_path(b, "b")
    return _programme(_dtw_kernel, "sum", a_, b_) / max(len(a_), len(b_))


# ----------------------------------------------------------------------------- the registry


#: what a metric measures, and so which way is better: a correlation (R: 1 is the same shape) or
#: a distance (0 is the same path)
KINDS = {"correlation": "higher", "distance": "lower"}


@dataclass(frozen=True)
class Metric:
    """One score of a generated path ``a`` against a reference ``b``, registered by name.

    Attributes
    ----------
    name : str
        The name in ``results.json``, ``pairs.csv`` and every table (a per-axis metric ``r_axis``
        is reported as ``r_x``, ``r_y`` (, ``r_z``)).
    kind : str
        ``"correlation"`` (unit-free, at most 1, higher is better; printed with 3 decimals, drawn
        on a fixed scale) or ``"distance"`` (in the data's units, lower is better; drawn on a log
        scale): :data:`KINDS`.
    time_free : bool
        True when the score does not compare the paths sample by sample at equal normalised times
        (Fréchet, DTW, end-point error): it cannot reward a method for knowing *when* the person
        passed a point.
    unit : str
        ``"u"`` (the data's unit), ``"u²"`` or ``""`` (unit-free).
    title : str
        How tables name it ("Fréchet", "MSD").
    per_axis : bool
        True when ``compute`` returns one value per coordinate.
    headline : bool
        Shown in the headline tables and tested shape by shape (a score that is not time-free
        only where the protocol gives no timing away); the others stay in ``results.json``.
    paper : bool
        One of the paper's measures (§III.D: R, eq. 1, and MSD, eq. 2): its Tables I-III and the
        heatmaps ``hila eval`` draws show it.
    compute : callable
        ``(a, b, costs) -> float or ndarray (D,)`` on the two paths resampled to equal length and
        their point-to-point distance matrix.
    """

    name: str
    kind: str
    time_free: bool
    unit: str
    title: str
    per_axis: bool
    headline: bool
    paper: bool
    compute: Callable[[np.ndarray, np.ndarray, np.ndarray], Any]

    @property
    def better(self) -> str:
        """``"higher"`` or ``"lower"``: which way is better (the paired tests and "share won" read it)."""
        return KINDS[self.kind]


#: every metric of ``hila eval``, in report order; add one with :func:`register` (one place)
METRICS: dict[str, Metric] = {}


def register(name: str, kind: str, *, time_free: bool, unit: str, title: str | None = None, per_axis: bool = False,
             headline: bool = False, paper: bool = False):
    """Decorator: register ``compute(a, b, costs)`` as the metric ``name`` (see :class:`Metric`)."""
    if kind not in KINDS:
        raise ValueError(f"expected kind = {' or '.join(map(repr, KINDS))}, got {kind!r}")

    def add(compute):
        METRICS[name] = Metric(name, kind, time_free, unit, title or name, per_axis, headline, paper, compute)
        return compute

    return add


# R rises to ~0.99 for every template method and ignores scale and offset: kept, not a headline
register("r", "correlation", time_free=False, unit="", title="R", paper=True)(lambda a, b, c: _correlation(a, b))
register("msd", "distance", time_free=False, unit="u²", title="MSD", headline=True, paper=True)(
    lambda a, b, c: _msd(a, b))
register("frechet", "distance", time_free=True, unit="u", title="Fréchet", headline=True)(
    lambda a, b, c: _run(_frechet_kernel, "max", c))
register("dtw", "distance", time_free=True, unit="u", title="DTW", headline=True)(
    lambda a, b, c: _run(_dtw_kernel, "sum", c) / len(a))
register("endpoint", "distance", time_free=True, unit="u", title="end-point error")(
    lambda a, b, c: float(np.linalg.norm(a[-1] - b[-1])))
register("r_axis", "correlation", time_free=False, unit="", title="R per axis", per_axis=True)(
    lambda a, b, c: _axis_correlation(a, b))

AXES = "xyz"


def names(dim: int) -> tuple[str, ...]:
    """The reported score names for paths of dimension ``dim``, in :func:`scores` order."""
    out: list[str] = []
    for m in METRICS.values():
        out.extend(f"{m.name.rsplit('_', 1)[0]}_{a}" for a in AXES[:dim]) if m.per_axis else out.append(m.name)
    return tuple(out)


def metric(name: str) -> Metric:
    """The registered :class:`Metric` of a reported name (``r_x`` -> the per-axis R)."""
    if name in METRICS:
        return METRICS[name]
    for m in METRICS.values():
        if m.per_axis and name.rsplit("_", 1)[0] == m.name.rsplit("_", 1)[0] and name[-1:] in AXES:
            return m
    raise InputError(f"unknown metric {name!r}; expected one of {', '.join(names(3))}")


def scores(a: Any, b: Any) -> np.ndarray:
    """Every registered metric of a path ``a`` against a reference ``b``, after one check and one resampling.

    Returns
    -------
    ndarray, shape (len(names(D)),)
        In :func:`names` order (R, MSD, Fréchet, DTW per sample, end-point error, then R of each
        coordinate): the same numbers as :func:`correlation`, :func:`msd`, :func:`frechet`,
        :func:`dtw`, :func:`endpoint_error` and :func:`axis_correlation` of the two paths
        resampled to equal length (what ``hila eval`` scores; the Fréchet/DTW costs are computed once).
    """
    a, b = _paired(a, b)
    c = _costs(a, b)
    return np.hstack([np.atleast_1d(m.compute(a, b, c)) for m in METRICS.values()]).astype(float)
