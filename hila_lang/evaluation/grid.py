"""One row of the cross-mapping: a template trial mapped onto every task trial, N = 1..4 segments.

For a template trial i and a task trial j (the paper's "input" and "output") and a segment
count N, the constraint pairs are

- the scene ICPs the two trials share by name (template ICP → task ICP), and
- for N >= 2, the N − 1 inner segment boundaries of an equal-N split
  (:func:`hila_lang.segmentation.equal_segments`): the template's boundary point → the task
  path's boundary point (DESIGN.md §1; "each segment boundary adds a constraint pair").

The generated path is compared with trial j's own human path by R (eq. 1) and MSD (eq. 2) after
the shorter of the two is resampled by cubic spline to the longer's length
(:mod:`hila_lang.metrics`).  Methods:

- ``osila`` (the Tables): one :func:`hila_lang.osila.imitate` of the whole template with the
  scene pairs plus the boundary pairs;
- ``hila``: the segmented template run through the hierarchical generator
  (:func:`hila_lang.hierarchy.generate`): one OSILA per equal segment (a sub-template carrying
  ``start`` and ``end`` ICPs), the start pinned to the task's hand (then to where the previous
  piece ended), each inner ``end`` bound to the task path's point at the same equal split, the
  pieces stitched (a joint shared by two pieces appears once);
- the peers of :mod:`.peers` (``tps``: the bare warp; ``dmp``: per-segment DMPs).

Times are per generated path, measured in the worker around the generation only (not the
metrics); work a method does once per template (fitting the DMPs) is shared over its row.

A pair whose generation fails (a :class:`~hila_lang.errors.HilaError`, e.g. on a user's
degenerate ICPs) scores NaN and is counted, never aborts the grid.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import HilaError
from .dataset import Trial

SEGMENTS = (1, 2, 3, 4)
METHODS = ("osila", "hila", "tps", "dmp")


def boundaries(length: int, n: int) -> list[int]:
    """Indices of the N − 1 inner boundaries of an equal-N split of ``length`` points."""
    from ..segmentation import equal_segments

    return [start for start, _ in equal_segments(length, n)[1:]]


def shared_icps(template: Trial, task: Trial) -> tuple[np.ndarray, np.ndarray]:
    """ICPs both trials name, paired by name in the template's order: (src (K, D), dst (K, D))."""
    index = {name: k for k, name in enumerate(task.icp_names)}
    rows = [(k, index[name]) for k, name in enumerate(template.icp_names) if name in index]
    a = np.array([r[0] for r in rows], dtype=int)
    b = np.array([r[1] for r in rows], dtype=int)
    return template.icps[a], task.icps[b]


def constraint_pairs(template: Trial, task: Trial, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Scene ICP pairs plus the N − 1 boundary pairs (template boundary → task path boundary)."""
    src, dst = shared_icps(template, task)
    if n > 1:
        src = np.vstack([src, template.path[boundaries(len(template.path), n)]])
        dst = np.vstack([dst, task.path[boundaries(len(task.path), n)]])
    return src, dst


def score(generated: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """(R, MSD) of a generated path against the human one, after cubic-spline resampling."""
    from ..metrics import correlation, msd, resample

    n = max(len(generated), len(target))
    if len(generated) != n:
        generated = resample(generated, n)
    if len(target) != n:
        target = resample(target, n)
    return correlation(generated, target), msd(generated, target)


@dataclass
class RowResult:
    """Scores of one template row.

    Attributes
    ----------
    row : int
        Template (input) trial index.
    r, msd, seconds : dict of str to ndarray, shape (S, J)
        Per method: R, MSD and generation time per path (s) for each segment count and task.
    failures : dict of str to list of str
        Per method: ``"N=2 exp1/trial01 -> exp3/trial04: message"`` for each failed pair.
    """

    row: int
    r: dict[str, np.ndarray] = field(default_factory=dict)
    msd: dict[str, np.ndarray] = field(default_factory=dict)
    seconds: dict[str, np.ndarray] = field(default_factory=dict)
    failures: dict[str, list[str]] = field(default_factory=dict)


def _generator(method: str, template: Trial, options: dict[str, Any]):
    """A function (task, n) -> path for ``method``, prepared once per template."""
    if method == "osila":
        from ..osila import imitate

        def run(task: Trial, n: int) -> np.ndarray:
            src, dst = constraint_pairs(template, task, n)
            return imitate(template.path, src, dst, **options)

        return run
    if method == "hila":
        return _hila_generator(template, options)
    from . import peers

    if method == "tps":
        return lambda task, n: peers.tps_warp(template.path, *constraint_pairs(template, task, n))
    if method == "dmp":
        return peers.DmpPeer(template.path).generate
    raise ValueError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")


def _hila_generator(template: Trial, options: dict[str, Any]):
    """(task, n) -> stitched path of the equal-N sub-templates, via the hierarchical generator."""
    from ..hierarchy import generate
    from ..segmentation import equal_segments, segment_template
    from ..template import Template

    steps_cache: dict[tuple[frozenset, int], list] = {}

    def steps(shared: tuple[str, ...], n: int) -> list:
        key = (frozenset(shared), n)
        if key not in steps_cache:
            icps = {name: p for name, p in zip(template.icp_names, template.icps) if name in key[0]}
            whole = Template(template.label, template.path, icps, units="px")
            tags = [f"s{k + 1}" for k in range(n)]
            cut = segment_template(whole, n, tags, method="equal") if n > 1 else None
            steps_cache[key] = [cut.sub(t) for t in tags] if cut is not None else [whole]
        return steps_cache[key]

    def run(task: Trial, n: int) -> np.ndarray:
        shared = tuple(name for name in template.icp_names if name in task.icp_names)
        scene = {name: task.icps[task.icp_names.index(name)] for name in shared}
        ends = [stop - 1 for _, stop in equal_segments(len(task.path), n)]
        tasks = [{**scene, "end": task.path[e]} for e in ends[:-1]] + [scene]
        hand = scene.get("hand", task.path[0])
        return generate(steps(shared, n), tasks, start=hand if n > 1 else None, **options).path

    return run


def evaluate_row(
    trials: list[Trial],
    row: int,
    segments: tuple[int, ...] = SEGMENTS,
    methods: tuple[str, ...] = ("osila",),
    options: dict[str, Any] | None = None,
) -> RowResult:
    """Map trial ``row`` onto every trial for each segment count and method, and score it.

    Parameters
    ----------
    trials : list of Trial
        The dataset (templates and tasks are the same trials).
    row : int
        Index of the template trial.
    segments : tuple of int
        Segment counts N.
    methods : tuple of str
        Any of ``osila``, ``tps``, ``dmp``.
    options : dict, optional
        Options passed to :func:`hila_lang.osila.imitate` (``threshold`` etc.).

    Returns
    -------
    RowResult
    """
    options = dict(options or {})
    template = trials[row]
    out = RowResult(row)
    for method in methods:
        shape = (len(segments), len(trials))
        r, m, sec = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan)
        fails: list[str] = []
        t0 = time.perf_counter()
        gen = _generator(method, template, options)
        setup_time = time.perf_counter() - t0  # e.g. fitting the DMPs, shared by the row
        for s, n in enumerate(segments):
            for j, task in enumerate(trials):
                t0 = time.perf_counter()
                try:
                    path = gen(task, n)
                except HilaError as exc:
                    fails.append(f"N={n} {template.label} -> {task.label}: {exc.message}")
                    continue
                sec[s, j] = time.perf_counter() - t0 + setup_time / sec.size
                r[s, j], m[s, j] = score(path, task.path)
        out.r[method], out.msd[method], out.seconds[method], out.failures[method] = r, m, sec, fails
    return out


def evaluate_rows(trials, rows, segments=SEGMENTS, methods=("osila",), options=None) -> list[RowResult]:
    """:func:`evaluate_row` for several rows (one unit of parallel work)."""
    return [evaluate_row(trials, i, segments, methods, options) for i in rows]
