"""Find library parts in a new demonstration: where, how big, how turned and how fast made.

The steps (:func:`recognise`):

1. The demonstration is smoothed lightly and re-sampled at equal arc-length steps (M points,
   M = its sample count, clipped to [:data:`MIN_POINTS`, :data:`MAX_POINTS`]), so speed and
   pauses do not matter (:mod:`.shape`).
2. **Search** (stumpy's ``mass``): the heading signal of every library part, re-sampled to each
   length of a geometric ladder (ratio :data:`LADDER`, from :data:`MIN_STEPS` steps to the whole
   demonstration: every size), is slid along the demonstration's heading signal.  ``mass``
   returns the Euclidean distance profile (``normalize=False``: z-normalising would divide away
   how much a shape turns); the turn of each window is removed exactly by subtracting
   (n − 1)·(window mean − part mean)² from the squared distance of the heading column.  The
   local minima of each profile below :data:`HEADING_GATE` (RMS radians) are candidates.
3. **Verification**: every candidate window is compared with the part by the Procrustes
   distance (similarity-invariant, :func:`.shape.procrustes_distance`); the best of each
   cluster has its two ends moved to nearby samples where the hand slows (:func:`_settle`), to
   the lowest distance; the survivors under :data:`GATE` are scored by the elastic distance
   (:func:`.shape.elastic_distance`: Procrustes with the pairing re-chosen by dtaidistance's DTW).
4. **Selection**: among windows closer than ``threshold``, the set of non-overlapping windows
   with the largest total of arc length × (1 − distance / threshold) (weighted interval
   scheduling): a whole known shape beats a fragment of it that happens to fit slightly better.
5. What no known part covers is *new*.

Why stumpy's ``mass``: a measurement on this machine (load ~0.3, 2 cores) of one part against an
800-point demonstration: ``stumpy.mass`` 0.10 ms per call at any part length (FFT), dtaidistance's
subsequence DTW (C) 0.56 ms at 64 points and growing with the part's length; the 50-template goal
takes ~40 lengths × 50 parts = 2000 calls, 0.2 s with ``mass`` and > 1 s with DTW.  DTW's
elasticity is not needed after arc-length re-sampling (speed is gone), and a turn shifts the
heading by a constant, which DTW cannot remove per window and ``mass``'s profile can.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from ..core.validation import check_path
from .library import REFERENCE_POINTS, Entry
from .shape import arc_length, arc_resample, elastic_distance, heading, procrustes_distance, smooth

#: the demonstration is re-sampled to this many arc-length points at least / at most
MIN_POINTS, MAX_POINTS = 64, 400
#: shortest searched part, arc-length steps (below it a heading curve is a few noisy angles)
MIN_STEPS = 12
#: ratio between consecutive searched lengths: a part σ times bigger is tried within ±5 %
LADDER = 1.1
#: RMS heading error (radians) under which a window is a candidate; the Procrustes distance decides.
#: Measured: demonstration 1 of each LASA development shape against its other six, at 24 and 64
#: points, 0.19 median, 0.53 at most: 0.6 lets every same-shape window through
HEADING_GATE = 0.6
#: plain Procrustes distance under which a window is verified further: the same LASA development
#: shape, one demonstration against another, is 0.214 at most (shape.elastic_distance's docstring)
GATE = 0.25
#: elastic distance (:func:`.shape.elastic_distance`) under which a window is a known part:
#: midway between the largest same-shape distance (0.106) and the smallest other-shape distance
#: (0.123) measured on LASA's development shapes (never the held-out ones)
THRESHOLD = 0.115
#: a known part's ends are where the hand is slower than SLOW × the part's median speed.  Measured
#: (smoothed, 50 Hz): the first/last samples of all 98 LASA development demonstrations are under
#: 0.52 × their median speed (median 0.08), the tic-tac-toe model's reach/draw/retract ends under 0.48
SLOW = 0.6
#: how far an end may move to reach a slow sample, as a fraction of the part's length
SNAP = 0.15
#: samples at the end of a still-arriving demonstration where no part may end (the smoothing's
#: Gaussian, SMOOTH_SAMPLES = 1.5, reaches 2 sigma into the held end)
EDGE = 3
#: a new stretch next to a known part along which the hand moved less than SLIVER × that part's
#: arc length is given to it (:func:`_absorb_slivers`); 0.05: the issue's boundary tolerance
SLIVER = 0.05
#: slow samples tried per end (the local minima of the speed, slowest first)
SNAP_CHOICES = 6


@dataclass
class Part:
    """One stretch of the demonstration.

    ``start``/``end`` are samples (end exclusive); ``template``/``tag`` name the library part it
    is (both ``None`` for a new stretch); ``distance`` the Procrustes distance (``None`` if new);
    ``confidence`` = 1 − distance / threshold; ``t_start``/``t_end`` seconds.
    """

    start: int
    end: int
    template: str | None = None
    tag: str | None = None
    distance: float | None = None
    confidence: float | None = None
    t_start: float = 0.0
    t_end: float = 0.0
    source: str = ""

    @property
    def known(self) -> bool:
        return self.template is not None

    def as_report(self) -> dict:
        return {"start": int(self.start), "end": int(self.end), "template": self.template, "tag": self.tag,
                "distance": None if self.distance is None else round(float(self.distance), 6)}


def _ladder(longest: int) -> np.ndarray:
    n, out = float(MIN_STEPS), []
    while n <= longest:
        out.append(int(round(n)))
        n *= LADDER
    return np.unique(np.array(out or [longest], int))


def _windows(q: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Windows [lo, hi] (fractional indices of ``q``) re-sampled to REFERENCE_POINTS: (W, R, D)."""
    u = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, REFERENCE_POINTS)[None, :]
    i = np.clip(np.floor(u).astype(int), 0, len(q) - 2)
    w = (u - i)[..., None]
    return q[i] * (1 - w) + q[i + 1] * w


def _local_minima(profile: np.ndarray, gate: float, zone: int) -> np.ndarray:
    """Indices of the minima of ``profile`` below ``gate``, at least ``zone`` apart (best first)."""
    order = np.argsort(profile)
    order = order[profile[order] < gate]
    taken = np.zeros(len(profile), bool)
    out = []
    for i in order:
        if not taken[i]:
            out.append(i)
            taken[max(0, i - zone): i + zone + 1] = True
    return np.array(out, int)


def _candidates(q: np.ndarray, signal: np.ndarray, entry: Entry) -> list[tuple[float, float, float]]:
    """(lo, hi, distance) windows of ``q`` (indices) where ``entry`` may be, verified and refined."""
    # lazy: loads numba, scipy, yaml, which importing this module does not
    import stumpy

    m = len(signal)
    csum = np.concatenate([[0.0], np.cumsum(signal[:, 0])])
    lo, hi = [], []
    for n in _ladder(m):
        steps = n - 1
        part = entry.signal(n)
        if len(part) > m or steps < 2:
            continue
        sq = np.zeros(m - steps + 1)
        finite = np.ones(m - steps + 1, bool)
        for c in range(signal.shape[1]):
            # what stumpy.mass(..., normalize=False) calls, without its per-call checks (5x faster)
            sq += stumpy.core.mass_absolute(part[:, c], signal[:, c], T_subseq_isfinite=finite) ** 2
        mean_q = (csum[steps:] - csum[:-steps]) / steps
        sq -= steps * (mean_q - part[:, 0].mean()) ** 2
        rms = np.sqrt(np.maximum(sq, 0.0) / steps)
        for i in _local_minima(rms, HEADING_GATE, max(1, steps // 4)):
            lo.append(i)
            hi.append(i + steps)
    if not lo:
        return []
    lo, hi = np.array(lo, float), np.array(hi, float)
    d = procrustes_distance(_windows(q, lo, hi), entry.points)
    keep = d < GATE * 1.3  # moving the ends can bring a near miss under the gate
    lo, hi, d = lo[keep], hi[keep], d[keep]
    out = []
    used = np.zeros(len(d), bool)
    for k in np.argsort(d):  # the best of each cluster of overlapping windows
        if used[k]:
            continue
        inter = np.clip(np.minimum(hi, hi[k]) - np.maximum(lo, lo[k]), 0, None)
        union = np.maximum(hi, hi[k]) - np.minimum(lo, lo[k])
        used |= inter / union > 0.5
        out.append((float(lo[k]), float(hi[k]), float(d[k])))
    return out


def _slow(v: np.ndarray, centre: int, reach: int, limit: float) -> np.ndarray:
    """Samples within ``reach`` of ``centre`` where the speed is under ``limit``: the local minima and the slowest."""
    a, b = max(0, centre - reach), min(len(v), centre + reach + 1)
    w = v[a:b]
    inner = np.flatnonzero((w[1:-1] <= w[:-2]) & (w[1:-1] <= w[2:])) + 1
    pick = np.unique(np.concatenate([inner, [int(np.argmin(w))]]))
    pick = pick[w[pick] < limit]
    return a + pick[np.argsort(w[pick])][:SNAP_CHOICES]


def _settle(q, entry: Entry, arc_of: np.ndarray, v: np.ndarray, a0: int, b0: int, last: int | None = None):
    """Move the ends of samples [a0, b0] to where the hand slows, to the lowest Procrustes distance.

    Each end may go to a slow sample (speed under :data:`SLOW` × the window's median speed)
    within :data:`SNAP` × its length; ``None`` if an end has none: a part of a demonstration
    begins and ends where the hand slows (the rule the speed segmenter stands on).
    """
    reach = max(2, int(round(SNAP * (b0 - a0))))
    limit = SLOW * float(np.median(v[a0:b0 + 1]))
    starts, ends = _slow(v, a0, reach, limit), _slow(v, b0, reach, limit)
    if last is not None:
        ends = ends[ends <= last]
    if not len(starts) or not len(ends):
        return None
    A, B = np.meshgrid(starts, ends, indexing="ij")
    ok = arc_of[B] - arc_of[A] >= MIN_STEPS
    if not ok.any():
        return None
    d = np.full(A.shape, np.inf)
    d[ok] = procrustes_distance(_windows(q, arc_of[A[ok]], arc_of[B[ok]]), entry.points)
    i, j = np.unravel_index(np.argmin(d), d.shape)
    if d[i, j] >= GATE:
        return None
    a, b = int(A[i, j]), int(B[i, j])
    return a, b, elastic_distance(_windows(q, arc_of[[a]], arc_of[[b]])[0], entry.points)


def _schedule(cands: list[tuple[float, float, float, int]]) -> list[tuple[float, float, float, int]]:
    """Non-overlapping subset with the largest Σ (hi − lo)(1 − d / THRESHOLD) (weighted interval scheduling)."""
    cands = sorted(cands, key=lambda c: c[1])
    ends = np.array([c[1] for c in cands])
    best = [0.0] * (len(cands) + 1)
    take = [False] * len(cands)
    prev = [int(np.searchsorted(ends, c[0], side="right")) for c in cands]
    for k, (lo, hi, d, _) in enumerate(cands):
        with_k = best[prev[k]] + (hi - lo) * (1.0 - d / THRESHOLD)
        take[k] = with_k > best[k]
        best[k + 1] = max(best[k], with_k)
    out, k = [], len(cands) - 1
    while k >= 0:
        if take[k]:
            out.append(cands[k])
            k = prev[k] - 1
        else:
            k -= 1
    return out[::-1]


def _absorb_slivers(parts: list[Part], s: np.ndarray) -> list[Part]:
    """Give a new stretch along which the hand moved no more than SLIVER × the arc length of a
    known neighbour to that neighbour (both: split midway).

    Such a stretch is the rest of a pause whose slow samples were split between two parts, or
    the tremor before a known part begins: the hand did not do anything there.
    """
    arc = lambda q: float(s[q.end - 1] - s[q.start])  # noqa: E731
    out: list[Part] = []
    for k, p in enumerate(parts):
        if p.known:
            out.append(p)
            continue
        before = out[-1] if out and out[-1].known else None
        after = parts[k + 1] if k + 1 < len(parts) and parts[k + 1].known else None
        n = p.end - p.start
        moved = float(s[min(p.end, len(s) - 1)] - s[max(p.start - 1, 0)])  # with the steps into and out of it
        fits = [q for q in (before, after) if q is not None and moved <= SLIVER * arc(q)]
        if not fits:
            out.append(p)
        elif len(fits) == 2:
            before.end = after.start = p.start + n // 2
        elif fits[0] is before:
            before.end = p.end
        else:
            after.start = p.start
    return out


def recognise(path, entries: list[Entry], times=None, *, open_end: bool = False) -> list[Part]:
    """Cut ``path`` into known library parts and new stretches, in time order, covering it.

    Parameters
    ----------
    path : array_like, shape (T, D)
        The new demonstration.
    entries : list of Entry
        The library parts (:func:`.library.load_library`); those of another D are not searched.
    times : array_like, shape (T,), optional
        Seconds; 20 Hz is assumed when absent (only the reported seconds use it).
    open_end : bool
        The demonstration is still arriving (:mod:`.online`): no part may end in its last
        :data:`EDGE` samples, where the smoothing's held end looks like the hand slowing down.

    Returns
    -------
    list of Part
        Contiguous, ``[0, T)`` covered.
    """
    path = check_path(path, "demonstration path")
    T, D = path.shape
    times = np.arange(T) / 20.0 if times is None else np.asarray(times, float)
    usable = [e for e in entries if e.dim == D]
    if entries and not usable:
        raise InputError(f"the library's templates are {entries[0].dim}-D, the demonstration is {D}-D")
    sm = smooth(path)
    s = arc_length(sm)
    found: list[tuple[float, float, float, int]] = []
    if s[-1] > 0 and T >= 4:
        # lazy: only this branch needs it
        from ..osila.segmentation import speed

        m = int(np.clip(T, MIN_POINTS, MAX_POINTS))
        q = arc_resample(sm, m, s)
        signal = heading(q)
        arc_of = s / (s[-1] / (m - 1))  # sample -> fractional index of q
        keep = np.concatenate([[True], np.diff(s) > 0])
        samples = np.flatnonzero(keep)
        v = speed(sm, times)
        for k, entry in enumerate(usable):
            for lo, hi, _ in _candidates(q, signal, entry):
                a0, b0 = (int(round(np.interp(x, arc_of[keep], samples))) for x in (lo, hi))
                settled = _settle(q, entry, arc_of, v, a0, b0, T - 1 - EDGE if open_end else None)
                if settled is not None and settled[2] < THRESHOLD:
                    found.append((*settled, k))
    chosen = _schedule(found) if found else []
    parts: list[Part] = []
    cursor = 0
    for lo, hi, d, k in chosen:
        a = int(np.clip(lo, cursor, T - 1))
        b = int(np.clip(hi + 1, a + 1, T))
        if a > cursor:
            parts.append(Part(cursor, a))
        e = usable[k]
        parts.append(Part(a, b, e.template, e.tag, d, 1.0 - d / THRESHOLD, source=e.source))
        cursor = b
    if cursor < T:
        parts.append(Part(cursor, T))
    if open_end and len(parts) > 1 and not parts[-1].known:  # the newest samples are not a sliver yet
        parts = [*_absorb_slivers(parts[:-1], s), parts[-1]]
    else:
        parts = _absorb_slivers(parts, s)
    for p in parts:
        p.t_start, p.t_end = float(times[p.start]), float(times[p.end - 1])
    return parts
