"""Template segmentation: k-means on spatio-temporal features, or equal-N splitting.

:func:`kmeans_segments` clusters waypoints on features [normalised position, time_weight ·
normalised time] with scikit-learn's ``KMeans`` (seeded, ``n_init=10``, deterministic).  k-means
labels need not be contiguous in time, so the clusters are ordered by their mean time and every
waypoint is then assigned, by a small dynamic programme, to a non-decreasing cluster sequence
that uses every cluster (minimum total squared feature distance to the cluster centres).  The
result is always k non-empty, contiguous, time-ordered segments covering the path.

Positions are centred and divided by the path's largest bounding-box side; time (given, or the
index) is scaled to [0, 1].  ``time_weight`` (default 1) trades spatial grouping against
contiguity.
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np

from .errors import InputError
from .template import Segment, Template
from .validation import check_int, check_path

METHODS = ("kmeans", "equal")


def equal_segments(T: int, n: int) -> list[tuple[int, int]]:
    """Split ``T`` stamps into ``n`` contiguous ``[start, stop)`` ranges of (nearly) equal size."""
    T = check_int(T, "T", minimum=1)
    n = check_int(n, "n", minimum=1)
    if n > T:
        raise InputError(f"cannot split {T} points into {n} non-empty segments (expected n <= {T})")
    cuts = [round(i * T / n) for i in range(n + 1)]
    return [(cuts[i], cuts[i + 1]) for i in range(n)]


def _ordered_assignment(cost: np.ndarray) -> np.ndarray:
    """Non-decreasing labels 0..k-1 (each used) minimising Σ cost[t, label_t]; cost (T, k)."""
    T, k = cost.shape
    best = np.full((T, k), np.inf)
    came = np.zeros((T, k), dtype=bool)  # True: label increased at t
    best[0, 0] = cost[0, 0]
    for t in range(1, T):
        stay = best[t - 1]
        step = np.concatenate([[np.inf], best[t - 1, :-1]])
        came[t] = step < stay
        best[t] = np.minimum(stay, step) + cost[t]
    labels = np.empty(T, dtype=int)
    c = k - 1
    for t in range(T - 1, -1, -1):
        labels[t] = c
        if t > 0 and came[t, c]:
            c -= 1
    return labels


def kmeans_segments(
    path: Any, k: int, *, times: Any = None, seed: int = 0, time_weight: float = 1.0
) -> list[tuple[int, int]]:
    """Split a path into ``k`` contiguous, time-ordered ``[start, stop)`` ranges by k-means.

    Parameters
    ----------
    path : array_like, shape (T, D)
    k : int
        Number of segments, 1 <= k <= T.
    times : array_like, shape (T,), optional
        Time stamps (seconds); the index is used when absent.
    seed : int
        ``random_state`` of ``KMeans``.
    time_weight : float
        Weight of the normalised time feature.

    Returns
    -------
    list of (start, stop)
        Covering ``[0, T)`` in order.
    """
    from sklearn.cluster import KMeans

    path = check_path(path, "path")
    T = path.shape[0]
    k = check_int(k, "k", minimum=1)
    if k > T:
        raise InputError(f"cannot split {T} points into k = {k} segments (expected k <= {T})")
    if k == 1:
        return [(0, T)]
    t = np.arange(T, dtype=float) if times is None else np.asarray(times, dtype=float)
    if t.shape != (T,) or not np.isfinite(t).all():
        raise InputError(f"expected times of shape ({T},), finite, got {t.shape}")
    span = float(t[-1] - t[0]) or 1.0
    extent = float(np.ptp(path, axis=0).max()) or 1.0
    feats = np.column_stack([(path - path.mean(0)) / extent, time_weight * (t - t[0]) / span])
    km = KMeans(n_clusters=k, n_init=10, random_state=check_int(seed, "seed")).fit(feats)
    centres = km.cluster_centers_[np.argsort(km.cluster_centers_[:, -1])]
    cost = ((feats[:, None, :] - centres[None, :, :]) ** 2).sum(-1)
    labels = _ordered_assignment(cost)
    cuts = np.flatnonzero(np.diff(labels)) + 1
    bounds = [0, *cuts.tolist(), T]
    return [(bounds[i], bounds[i + 1]) for i in range(k)]


def segment_template(
    template: Template,
    k: int,
    tags: Sequence[str],
    method: str = "kmeans",
    seed: int = 0,
    contact: Iterable[str] = (),
) -> Template:
    """A copy of ``template`` with ``k`` tagged segments.

    Parameters
    ----------
    template : Template
    k : int
        Number of segments.
    tags : sequence of str
        One tag per segment, in time order, unique.
    method : {"kmeans", "equal"}
    seed : int
        k-means seed.
    contact : iterable of str
        Tags whose segments touch the surface (``Segment.contact``).

    Raises
    ------
    InputError
        Wrong number of tags, unknown method, a contact tag that is not among the tags.
    """
    tags = list(tags)
    if len(tags) != k:
        raise InputError(f"expected {k} tags for k = {k} segments, got {len(tags)}: {', '.join(tags)}")
    contact = set(contact)
    unknown = sorted(contact - set(tags))
    if unknown:
        raise InputError(f"contact tag {unknown[0]!r} is not one of the tags {', '.join(tags)}")
    if method == "kmeans":
        ranges = kmeans_segments(template.path, k, times=template.times, seed=seed)
    elif method == "equal":
        ranges = equal_segments(len(template.path), k)
    else:
        raise InputError(f"unknown segmentation method {method!r}; expected one of {', '.join(METHODS)}")
    segments = [Segment(tag, a, b, tag in contact) for tag, (a, b) in zip(tags, ranges)]
    return Template(
        name=template.name,
        path=template.path.copy(),
        icps={n: p.copy() for n, p in template.icps.items()},
        times=None if template.times is None else template.times.copy(),
        segments=segments,
        description=template.description,
        units=template.units,
    )
