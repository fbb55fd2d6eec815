"""The strongest baselines we could build: via-point methods from the literature, on OSILA's constraints.

Each is a function ``(constraints) -> path (T, D)`` prepared once per template, like the controls
(:mod:`.controls`), and gets exactly the :class:`~.protocols.Constraints` OSILA gets.  All three
start from the template moved by the least-squares similarity of the constraint pairs (the
``similarity`` control: the demonstration's shape in the task's frame) and add a smooth offset in
time that makes the path pass the task point of every *anchor* exactly (:func:`.controls.anchors`:
the pairs whose template point lies on the template path, at that template stamp, and the ends).
They differ in the offset:

``promp``
    A ProMP (``movement_primitives.promp.ProMP``, Paraschos et al. 2013) over the offset,
    conditioned on each anchor's offset at the anchor's template time.  ``ProMP.via_points``
    broadcasts an (n, D, D) covariance wrongly, so the ProMP is conditioned one point at a time
    (``condition_position``, exactly: zero observation covariance), and its mean is the offset.
    Settings: the package's defaults (10 Gaussian basis functions per dimension, its overlap, an
    identity prior over the weights); with one demonstration there is nothing to learn a weight
    distribution from, and the conditional mean does not depend on the prior's scale.
``laplacian``
    Laplacian trajectory editing (Nierhoff, Hirche & Nakamura 2016): the path keeps the
    template's discrete Laplacian coordinates δ = L p (each point minus the mean of its
    neighbours; the similarity-aligned template's, so the edit is invariant to the frame) in the
    least-squares sense, subject to the anchors as hard positional constraints.  No setting.
``gp``
    A Gaussian process over the offset (scikit-learn's RBF kernel, zero mean, exact
    interpolation: ``GaussianProcessRegressor``'s posterior mean, as a cached matrix): the via-point form of kernelised movement primitives.  Its
    length scale is the one the template's own movement shows: the maximum-marginal-likelihood
    RBF length scale of a GP (RBF + white noise) fitted to the template's coordinates against
    time, once per template.  Nothing is chosen on a task or against OSILA.

``X+retime`` runs ``X`` on the template re-timed by OSILA's own re-timing
(:func:`hila_lang.osila.timing.retime` with OSILA's spread, ``--timing`` or its default, and the
pairs' task times: the pairs that carry a time are re-estimated): which part of the template
passes each on-path pair is re-estimated first, as OSILA does before its warp.  So the re-timing's
contribution can be told apart from the warp's.  Where no pair carries a time (the leak-free
protocols) OSILA re-times nothing, and ``X+retime`` is ``X``.
"""

from __future__ import annotations

import warnings
from functools import lru_cache
from typing import Callable

import numpy as np

from ..core.errors import InputError
from ..osila.pathwarp import offsets_matrix
from ..osila.timing import retime, TIMING
from .controls import _apply, anchors, similarity
from .protocols import Constraints

BASELINES = ("promp", "promp+retime", "laplacian", "laplacian+retime", "gp", "gp+retime")


def _edit(path: np.ndarray, c: Constraints, offset: Callable[[int, np.ndarray, np.ndarray], np.ndarray]) -> np.ndarray:
    """The similarity-aligned template plus ``offset(T, anchor stamps (A,), anchor offsets (A, D))``,
    through the anchors exactly (each method meets them to rounding)."""
    aligned = _apply(similarity(c), path)
    idx, points = anchors(path, c)
    out = aligned + offset(len(path), idx, points - aligned[idx])
    out[idx] = points
    return out


# ----------------------------------------------------------------------------- ProMP


def promp_offset(T: int, idx: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """The mean of a default ProMP conditioned on ``offsets`` (A, D) at stamps ``idx``, shape (T, D)."""
    # lazy: loads movement_primitives, which importing this module does not
    from movement_primitives.promp import ProMP

    D = offsets.shape[1]
    promp = ProMP(n_dims=D)
    span = max(T - 1, 1)
    for t, y in zip(idx, offsets):  # one point at a time: via_points mis-broadcasts (n, D, D) covariances
        promp = promp.condition_position(y, np.zeros((D, D)), t=float(t) / span, t_max=1.0)
    return promp.mean_trajectory(np.linspace(0.0, 1.0, T))


def promp(path: np.ndarray, c: Constraints) -> np.ndarray:
    return _edit(path, c, promp_offset)


# ----------------------------------------------------------------------------- Laplacian editing


def _laplacian_edit(T: int, idx: tuple[int, ...]) -> np.ndarray:
    """(T, A): the offset e minimising |L e|² with e = r at the anchors, linear in r (cached).

    The edited path q = p + e keeps δ = L p best (|L q − δ|² = |L e|²), so only the offset is solved.
    L is the path graph's uniform Laplacian: row t is e_t − mean of its neighbours.  OSILA's path
    warp solves the same system (:func:`hila_lang.osila.pathwarp.offsets_matrix`); the baseline is
    it undamped (μ = 0), as Nierhoff et al. edit.
    """
    return offsets_matrix(T, idx, 0.0)


def laplacian(path: np.ndarray, c: Constraints) -> np.ndarray:
    return _edit(path, c, lambda T, idx, off: _laplacian_edit(T, tuple(idx.tolist())) @ off)


# ----------------------------------------------------------------------------- GP


#: the length-scale fit sees at most this many template samples, evenly spaced in time (a
#: fraction of the duration does not depend on the sampling; the fit's cost grows as its cube)
FIT_SAMPLES = 50


def template_length_scale(path: np.ndarray) -> float:
    """The RBF length scale (fraction of the duration) of the template's own movement: maximum
    marginal likelihood of an RBF + white-noise GP on its centred, unit-scaled coordinates
    (at most :data:`FIT_SAMPLES` samples; once per template, cached)."""
    path = np.asarray(path, float)
    return _length_scale(path.shape, path.tobytes())


@lru_cache(maxsize=256)
def _length_scale(shape: tuple[int, int], data: bytes) -> float:
    # lazy: loads sklearn, scipy, threadpoolctl, which importing this module does not
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, WhiteKernel

    path = np.frombuffer(data).reshape(shape)
    pick = np.unique(np.round(np.linspace(0, shape[0] - 1, min(shape[0], FIT_SAMPLES))).astype(int))
    u = np.linspace(0.0, 1.0, shape[0])[pick, None]
    y = path[pick] - path[pick].mean(0)
    y = y / max(float(np.abs(y).max()), 1e-12)
    kernel = RBF(0.1, (1e-3, 10.0)) + WhiteKernel(1e-4, (1e-10, 1.0))
    with warnings.catch_warnings():  # a bound reached is an answer here (the smoothest or roughest allowed)
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp = GaussianProcessRegressor(kernel, normalize_y=False, random_state=0).fit(u, y)
    return float(gp.kernel_.k1.length_scale)


@lru_cache(maxsize=4096)
def _gp_matrix(T: int, idx: tuple[int, ...], length_scale: float) -> np.ndarray:
    """(T, A): the posterior mean of a zero-mean RBF GP (scikit-learn's kernel) interpolating values
    at stamps ``idx``, sampled at every stamp: k(u, U) k(U, U)⁻¹ (linear in the values; cached)."""
    # lazy: loads sklearn, scipy, threadpoolctl, which importing this module does not
    from sklearn.gaussian_process.kernels import RBF

    u = np.linspace(0.0, 1.0, T)[:, None]
    kernel = RBF(length_scale)
    K = kernel(u[list(idx)]) + 1e-10 * np.eye(len(idx))  # GaussianProcessRegressor's default alpha
    out = np.linalg.solve(K, kernel(u[list(idx)], u)).T
    out.flags.writeable = False
    return out


def gp_offset(T: int, idx: np.ndarray, offsets: np.ndarray, length_scale: float) -> np.ndarray:
    """The posterior mean of an RBF GP interpolating ``offsets`` (A, D) at stamps ``idx``, (T, D)
    (what ``GaussianProcessRegressor(RBF(length_scale), optimizer=None)`` predicts; the tests check)."""
    return _gp_matrix(T, tuple(idx.tolist()), float(length_scale)) @ offsets


class GpBaseline:
    """``gp`` for one template: the length scale once (:func:`template_length_scale`), then per pair."""

    def __init__(self, path: np.ndarray) -> None:
        self.path = path
        self.length_scale = template_length_scale(path) if len(path) > 2 else 1.0

    def __call__(self, c: Constraints, path: np.ndarray | None = None) -> np.ndarray:
        path = self.path if path is None else path
        return _edit(path, c, lambda T, idx, off: gp_offset(T, idx, off, self.length_scale))


# ----------------------------------------------------------------------------- re-timing


_last: list = []  # the last re-timing: (path, constraints, timing, result)


def retime_once(path: np.ndarray, c: Constraints, timing: float, times=None):
    """:func:`hila_lang.osila.timing.retime` of one pair (with the pairs' task times ``times``,
    default ``c.times``), computed once for the several methods that run on the same pair in a row
    (the grid passes every method the same objects)."""
    times = c.times if times is None else times
    if _last and _last[0] is path and _last[1] is c and _last[2] == timing and _last[3] == times:
        return _last[4]
    moved = retime(path, c.src, c.dst, timing, times=times)
    _last[:] = [path, c, timing, times, moved]
    return moved


def retimed(path: np.ndarray, c: Constraints, timing: float | None = None) -> tuple[np.ndarray, Constraints]:
    """The template and constraints after OSILA's re-timing (spread ``timing``, default OSILA's)."""
    moved = retime_once(path, c, TIMING if timing is None else timing)
    if moved.path is path:
        return path, c
    return moved.path, Constraints(moved.src, c.dst, c.labels, c.at, c.n, c.times)


def generator(method: str, path: np.ndarray, options: dict | None = None) -> Callable[[Constraints], np.ndarray]:
    """A function constraints -> path (T, D) for one of :data:`BASELINES`, prepared once per template;
    ``options``: OSILA's, of which ``X+retime`` takes ``timing`` (``--timing``)."""
    base, _, retime_ = method.partition("+")
    if base == "promp":
        # lazy: only this branch needs it
        from .controls import require_dmp

        require_dmp()  # movement_primitives
        one: Callable[[np.ndarray, Constraints], np.ndarray] = promp
    elif base == "laplacian":
        one = laplacian
    elif base == "gp":
        gp = GpBaseline(path)

        def one(p: np.ndarray, c: Constraints) -> np.ndarray:
            return gp(c, p)
    else:
        raise InputError(f"unknown baseline {method!r}; expected one of {', '.join(BASELINES)}")
    if retime_:
        timing = (options or {}).get("timing")
        return lambda c: one(*retimed(path, c, timing))
    return lambda c: one(path, c)

