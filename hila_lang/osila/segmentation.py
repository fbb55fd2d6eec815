"""Template segmentation: cut a demonstration into ordered, contiguous, tagged phases.

Methods (:data:`METHODS`; :func:`segments` dispatches):

- ``speed`` (the default): cut at the k - 1 deepest dips in the hand's speed, where one stroke
  ends and the next begins (:func:`speed_segments`).
- ``kmeans`` (the paper's): k-means on spatio-temporal features (:func:`kmeans_segments`).
- ``changepoint``: change points of the velocity (:func:`changepoint_segments`).
- ``equal``: equal lengths (the controlled variant of the paper's Experiment A);
- ``contact``: where the pen touches and leaves the surface, as recorded (a demonstration CSV's
  ``pen`` column: a drawing's pointer events, a camera's pen tracking;
  :func:`contact_segments`).  ``hila learn`` uses it by default when the demonstration records
  the pen: the cuts then come from what happened, not from a guess at it.

Why ``speed`` is the default: ``bench/segmentation.py`` measures every method against known
phase boundaries of the project's seeded motion models — chains of minimum-jerk legs with random
durations (2 and 3 legs, 30 seeds each), the tic-tac-toe demonstration's five strokes (30
seeds), and ``primitives/circle.yaml`` as learned through the eye cameras against where the pen
touched and left the paper.  Mean cut error, in samples at 20 Hz: speed 0.5, equal 5.0,
changepoint 8.5, k-means 13.4; speed dips cut the learned circle at pen contact (99 % of samples
agree), k-means cuts it mid-stroke, near peak speed.

k-means: waypoints are clustered on features [normalised position, time_weight · normalised
time] with scikit-learn's ``KMeans`` (seeded, ``n_init=10``, deterministic).  k-means labels
need not be contiguous in time, so the clusters are ordered by their mean time and every
waypoint is then assigned, by a small dynamic programme, to a non-decreasing cluster sequence
that uses every cluster (minimum total squared feature distance to the cluster centres).
Positions are centred and divided by the path's largest bounding-box side; time (given, or the
index) is scaled to [0, 1].  ``time_weight`` (default 1) trades spatial grouping against
contiguity.

Every method returns k non-empty, contiguous, time-ordered ``[start, stop)`` ranges covering
the path.
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np

from ..core.errors import InputError
from .template import Segment, Template
from ..core.validation import check_int, check_path

METHODS = ("speed", "kmeans", "changepoint", "equal", "contact")
#: the default segmenter, chosen by ``bench/segmentation.py`` (see the module docstring)
DEFAULT_METHOD = "speed"


def describe(method: str, k: int) -> str:
    """How a template was segmented, one sentence for its description."""
    how = {"speed": "at the deepest dips in speed (hila_lang.osila.segmentation.speed_segments)",
           "kmeans": "by k-means", "changepoint": "by change points of the velocity",
           "equal": "into equal lengths",
           "contact": "where the pen touches and leaves the paper, as recorded "
                      "(hila_lang.osila.segmentation.contact_segments)"}[method]
    return f"Segmented {how} (k = {k})."


def equal_segments(T: int, n: int) -> list[tuple[int, int]]:
    """Split ``T`` stamps into ``n`` contiguous ``[start, stop)`` ranges of (nearly) equal size."""
    T = check_int(T, "T", minimum=1)
    n = check_int(n, "n", minimum=1)
    if n > T:
        raise InputError(f"cannot split {T} points into {n} non-empty segments (expected n <= {T})")
    cuts = [round(i * T / n) for i in range(n + 1)]
    return [(cuts[i], cuts[i + 1]) for i in range(n)]


def _checked(path: Any, k: int, min_size: int) -> tuple[np.ndarray, int, int]:
    """(path (T, D), T, k) validated for ``k`` segments of at least ``min_size`` points."""
    path = check_path(path, "path")
    T = path.shape[0]
    k = check_int(k, "k", minimum=1)
    if min_size * k > T:
        least = "" if min_size == 1 else f" of at least {min_size} points"
        most = T // min_size
        hint = (f"expected k <= {most}" if most >= 1 else
                f"a demonstration this short cannot be segmented: record at least {min_size} points, or use k = 1")
        raise InputError(f"cannot split {T} points into k = {k} segments{least} ({hint})")
    return path, T, k


def _ranges(cuts, T: int) -> list[tuple[int, int]]:
    """``[start, stop)`` ranges from inner cut indices."""
    bounds = [0, *sorted(int(c) for c in cuts), T]
    return [(bounds[i], bounds[i + 1]) for i in range(len(bounds) - 1)]


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
    # lazy: loads sklearn, scipy, threadpoolctl, which importing this module does not
    from sklearn.cluster import KMeans

    path, T, k = _checked(path, k, 1)
    if k == 1:
        return [(0, T)]
    t = _times(T, times)
    span = float(t[-1] - t[0]) or 1.0
    extent = float(np.ptp(path, axis=0).max()) or 1.0
    feats = np.column_stack([(path - path.mean(0)) / extent, time_weight * (t - t[0]) / span])
    km = KMeans(n_clusters=k, n_init=10, random_state=check_int(seed, "seed")).fit(feats)
    centres = km.cluster_centers_[np.argsort(km.cluster_centers_[:, -1])]
    cost = ((feats[:, None, :] - centres[None, :, :]) ** 2).sum(-1)
    labels = _ordered_assignment(cost)
    return _ranges(np.flatnonzero(np.diff(labels)) + 1, T)


def _times(T: int, times: Any) -> np.ndarray:
    t = np.arange(T, dtype=float) if times is None else np.asarray(times, dtype=float)
    if t.shape != (T,) or not np.isfinite(t).all():
        raise InputError(f"expected times of shape ({T},), finite, got {t.shape}")
    if T > 1 and not (np.diff(t) > 0).all():
        raise InputError("expected strictly increasing times")
    return t


def speed(path: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Speed at every sample (T,): central differences (one-sided at the ends), path units per second."""
    if len(path) < 2:
        return np.zeros(len(path))
    v = np.gradient(path, times, axis=0)
    return np.sqrt((v * v).sum(1))


def speed_segments(path: Any, k: int, *, times: Any = None) -> list[tuple[int, int]]:
    """Split a path into ``k`` segments at its ``k - 1`` deepest dips in speed.

    A human movement changes phase where the hand slows down between two strokes: the end of a
    reach before the pen touches, the end of a stroke before it lifts, the via points of a chain
    of minimum-jerk strokes.  The cuts are the ``k - 1`` local minima of the speed
    (:func:`speed`) with the largest prominence (``scipy.signal.find_peaks``: how far the speed
    must rise on both sides before it gets lower again — a dip between two strokes is deep, a
    flicker of tremor is not; ties go to the slower one), at least two samples apart and from
    the ends, so every segment has at least two points.  The slowest sample of a dip starts the
    next segment.  If the path has fewer dips, the remaining cuts go to the slowest remaining
    samples.

    Parameters
    ----------
    path : array_like, shape (T, D)
    k : int
        Number of segments, 1 <= k <= T // 2.
    times : array_like, shape (T,), optional
        Time stamps (seconds, strictly increasing); the index is used when absent.

    Returns
    -------
    list of (start, stop)
        Covering ``[0, T)`` in order.
    """
    path, T, k = _checked(path, k, 2)
    if k == 1:
        return [(0, T)]
    # lazy: loads scipy, which importing this module does not
    from scipy.signal import find_peaks

    v = speed(path, _times(T, times))
    dips, props = find_peaks(-v, prominence=0.0)  # local minima of the speed and how deep they are
    keep = (dips >= 2) & (dips <= T - 2)  # a cut at c makes [.., c) and [c, ..): both keep >= 2 points
    dips, prominence = dips[keep], props["prominences"][keep]
    rest = np.setdiff1d(np.arange(2, T - 1), dips)
    order = [*dips[np.lexsort((v[dips], -prominence))], *rest[np.argsort(v[rest], kind="stable")]]
    cuts: list[int] = []
    for c in order:
        if all(abs(int(c) - d) >= 2 for d in cuts):
            cuts.append(int(c))
            if len(cuts) == k - 1:
                break
    return _ranges(cuts, T)


def _split_gain(csum: np.ndarray, a: int, b: int, min_size: int) -> tuple[float, int]:
    """The best single cut ``c`` of ``[a, b)`` for the L2 cost and how much it lowers the cost.

    ``csum`` holds the prefix sums of the signal (a zero row first).  A span's cost is
    Σ|x - mean|² = Σ|x|² - |Σx|²/n, and the Σ|x|² terms cancel in the gain, so each candidate is
    O(D) and one pass over the candidate cuts O(b - a)."""
    c = np.arange(a + min_size, b - min_size + 1)
    if c.size == 0:
        return -np.inf, -1
    left, right, whole = csum[c] - csum[a], csum[b] - csum[c], csum[b] - csum[a]
    gain = ((left**2).sum(1) / (c - a) + (right**2).sum(1) / (b - c) - (whole**2).sum() / (b - a))
    best = int(np.argmax(gain))
    return float(gain[best]), int(c[best])


def changepoint_cuts(signal: Any, k: int, *, min_size: int = 2) -> list[int]:
    """The ``k - 1`` cuts that best explain ``signal`` (T, D) as piecewise constant (L2 cost).

    Binary segmentation -- the span whose best cut lowers the cost most is cut next -- then every
    cut is moved to its best place between its neighbours until none moves (each move lowers the
    cost, so it ends).  Prefix sums make a span's cost O(D), so the whole is O(k·T) per pass
    (issue 32: ``ruptures.Dynp``'s exact programme was O(T²) in time and memory, and one 5000-point
    demonstration took the studio down).  Not exact in general; on every seeded case of
    ``tests/test_core_segmentation.py`` its cost equals an exhaustive search's, and on
    ``bench/segmentation.py``'s cases it cuts where ``ruptures.Dynp``'s exact programme did.
    """
    x = np.asarray(signal, dtype=float)
    T = x.shape[0]
    csum = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)])
    csq = np.concatenate([[0.0], np.cumsum((x**2).sum(1))])
    bounds = [0, T]
    while len(bounds) < k + 1:
        gains = [_split_gain(csum, bounds[i], bounds[i + 1], min_size) for i in range(len(bounds) - 1)]
        gain, cut = max(gains)
        if cut < 0:
            break
        bounds = sorted(bounds + [cut])
    for _ in range(4 * T):  # refinement: a cut between fixed neighbours is a one-cut problem
        moved = False
        for i in range(1, len(bounds) - 1):
            _, cut = _split_gain(csum, bounds[i - 1], bounds[i + 1], min_size)
            if cut != bounds[i]:
                old = _span_cost(csum, csq, bounds[i - 1], bounds[i]) + _span_cost(csum, csq, bounds[i], bounds[i + 1])
                new = _span_cost(csum, csq, bounds[i - 1], cut) + _span_cost(csum, csq, cut, bounds[i + 1])
                if new < old - 1e-12 * max(1.0, old):
                    bounds[i], moved = cut, True
        if not moved:
            break
    return bounds[1:-1]


def _span_cost(csum: np.ndarray, csq: np.ndarray, a: int, b: int) -> float:
    """Σ|x - mean|² over ``[a, b)`` from the prefix sums."""
    s = csum[b] - csum[a]
    return float(csq[b] - csq[a] - (s**2).sum() / (b - a))


def changepoint_segments(path: Any, k: int, *, times: Any = None) -> list[tuple[int, int]]:
    """Split a path into ``k`` segments by change-point detection on its velocity.

    The ``k - 1`` cuts that best explain the velocity vectors (units per second) as piecewise
    constant, segments of at least two samples (:func:`changepoint_cuts`: O(k·T), so a long
    demonstration costs what a short one does per sample).
    """
    path, T, k = _checked(path, k, 2)
    if k == 1:
        return [(0, T)]
    v = np.gradient(path, _times(T, times), axis=0)
    return _ranges(changepoint_cuts(v, k, min_size=2), T)


def contact_segments(pen: Any, k: int, touching: Sequence[bool] | None = None) -> list[tuple[int, int]]:
    """Split a demonstration into ``k`` segments where the pen touches and leaves the surface.

    The cuts are chosen among the samples where the recorded pen changes (down after up, or up
    after down): the ``k - 1`` of them that put every pen-down sample in a segment whose contact
    flag (``touching``) is set, as far as they can -- ink outside a touching segment would never
    be drawn -- and then the fewest pen-up samples in touching segments (an exact dynamic
    programme over the changes; segments of at least two samples).  So ``reach, draw,
    retract`` with ``draw`` touching cuts at the first touch and the last lift, and the pen-up
    moves between the strokes of a mark stay in ``draw``; with as many changes as cuts it cuts
    at every change.
    Without ``touching`` the segments alternate, starting with the pen as it is at the first
    sample.

    Parameters
    ----------
    pen : array_like of bool, shape (T,)
        True where the pen touches the surface.
    k : int
        Number of segments.
    touching : sequence of k bool, optional
        Which segments touch the surface.

    Raises
    ------
    InputError
        The pen never changes, changes fewer than ``k - 1`` times where segments of two samples
        or more can start, or ``touching`` has the wrong length.
    """
    pen = np.asarray(pen, dtype=bool).ravel()
    T = len(pen)
    k = check_int(k, "k", minimum=1)
    if touching is None:
        touching = [bool(pen[0]) != bool(i % 2) for i in range(k)]
    touching = [bool(f) for f in touching]
    if len(touching) != k:
        raise InputError(f"expected {k} contact flags for k = {k} segments, got {len(touching)}")
    if k == 1:
        return [(0, T)]
    changes = [int(c) for c in np.flatnonzero(pen[1:] != pen[:-1]) + 1 if 2 <= c <= T - 2]
    if not changes:
        state = "touches the surface throughout" if pen.all() else "never touches the surface"
        raise InputError(f"cannot cut by the pen's contact: the pen {state} in the demonstration",
                         hint="record the pen (a drawing's pen down/up), or use --method speed")
    # mismatches of a segment [a, b) flagged f (prefix sums of the pen being down): a pen-down
    # sample left out of the touching segments outweighs every pen-up sample put in them
    down = np.concatenate([[0], np.cumsum(pen)])

    def cost(a: int, b: int, f: bool) -> int:
        inked = int(down[b] - down[a])
        return (b - a) - inked if f else inked * (T + 1)

    bounds = [0, *changes, T]
    n = len(bounds)
    best = np.full((k, n), np.inf)   # best[j, i]: segments 0..j with segment j ending at bounds[i]
    back = np.zeros((k, n), dtype=int)
    for i in range(1, n):
        if bounds[i] >= 2:
            best[0, i] = cost(0, bounds[i], touching[0])
    for j in range(1, k):
        for i in range(1, n):
            for h in range(1, i):
                if bounds[i] - bounds[h] >= 2 and best[j - 1, h] + cost(bounds[h], bounds[i], touching[j]) < best[j, i]:
                    best[j, i] = best[j - 1, h] + cost(bounds[h], bounds[i], touching[j])
                    back[j, i] = h
    if not np.isfinite(best[k - 1, n - 1]):
        raise InputError(f"cannot cut by the pen's contact into {k} segments: the pen changes only "
                         f"{len(changes)} time(s) (at samples {', '.join(map(str, changes))})",
                         hint="fewer tags, or --method speed")
    cuts, i = [], n - 1
    for j in range(k - 1, 0, -1):
        i = back[j, i]
        cuts.append(bounds[i])
    return _ranges(sorted(cuts), T)


def segments(path: Any, k: int, method: str = DEFAULT_METHOD, *, times: Any = None, seed: int = 0,
             pen: Any = None, touching: Sequence[bool] | None = None) -> list[tuple[int, int]]:
    """``k`` contiguous ``[start, stop)`` segments of ``path`` by ``method`` (one of :data:`METHODS`);
    ``contact`` needs ``pen`` (T,) and takes ``touching`` (:func:`contact_segments`)."""
    if method == "contact":
        if pen is None:
            raise InputError("segmentation method 'contact' needs the pen's contact at every sample "
                             "(a demonstration CSV with a 'pen' column)", hint="use --method speed")
        return contact_segments(pen, k, touching)
    if method == "speed":
        return speed_segments(path, k, times=times)
    if method == "kmeans":
        return kmeans_segments(path, k, times=times, seed=seed)
    if method == "changepoint":
        return changepoint_segments(path, k, times=times)
    if method == "equal":
        return equal_segments(len(check_path(path, "path")), k)
    raise InputError(f"unknown segmentation method {method!r}; expected one of {', '.join(METHODS)}")


def segment_template(
    template: Template,
    k: int,
    tags: Sequence[str],
    method: str = DEFAULT_METHOD,
    seed: int = 0,
    contact: Iterable[str] = (),
    pen: Any = None,
) -> Template:
    """A copy of ``template`` with ``k`` tagged segments.

    Parameters
    ----------
    template : Template
    k : int
        Number of segments.
    tags : sequence of str
        One tag per segment, in time order, unique.
    method : {"speed", "kmeans", "changepoint", "equal", "contact"}
        :data:`DEFAULT_METHOD` unless given.
    seed : int
        k-means seed.
    contact : iterable of str
        Tags whose segments touch the surface (``Segment.contact``).  With ``method="contact"``
        and none given, the segments where the recorded pen is down at most samples touch.
    pen : array_like of bool, shape (T,), optional
        The recorded pen (``method="contact"``).

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
    touching = [tag in contact for tag in tags] if contact else None
    ranges = segments(template.path, k, method, times=template.times, seed=seed, pen=pen, touching=touching)
    if method == "contact" and not contact:
        down = np.asarray(pen, dtype=bool)
        contact = {tag for tag, (a, b) in zip(tags, ranges) if 2 * down[a:b].sum() > b - a}
    parts = [Segment(tag, a, b, tag in contact) for tag, (a, b) in zip(tags, ranges)]
    return Template(
        name=template.name,
        path=template.path.copy(),
        icps={n: p.copy() for n, p in template.icps.items()},
        times=None if template.times is None else template.times.copy(),
        segments=parts,
        description=template.description,
        units=template.units,
    )
