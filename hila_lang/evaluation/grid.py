"""One row of the evaluation: a template trial mapped onto every task trial, for each N and method.

For a template trial i, a task trial j (the paper's "input" and "output") and a segment count N,
:func:`hila_lang.evaluation.protocols.constraints` builds the constraint pairs once; OSILA and
every control (:mod:`.controls`) get that same :class:`~.protocols.Constraints` object.  The
generated path is then compared with trial j's own human path (:func:`score`): the shorter of the
two is resampled by cubic spline to the longer's length (as in the paper), then

every metric registered in :data:`hila_lang.metrics.METRICS`: ``r`` (eq. 1, pooled over the
coordinates), ``msd`` (eq. 2, squared units), ``frechet`` and ``dtw`` (per sample), ``endpoint``
(units), and ``r_x``, ``r_y`` (, ``r_z``): R of each coordinate.

Methods: ``osila``; the controls ``none``, ``similarity``, ``tps``, ``dmp``, ``dmp-aligned``
(:mod:`.controls`); the baselines ``promp``, ``laplacian``, ``gp``, each also ``+retime``
(:mod:`.baselines`); the ablations ``osila-noroute``, ``-noretime``, ``-noadjust``, ``-tps``,
``-similarity`` (:mod:`.ablation`); and ``hila`` (paper protocol only): the segmented template run through the hierarchical
generator (:func:`hila_lang.hierarchy.generate.generate`), one OSILA per equal segment, each sub-template
carrying ``start`` and ``end`` ICPs, the start bound to the task's hand (then to where the
previous piece ended), each inner ``end`` bound to that boundary's task point, pieces stitched.

Times are per generated path, measured in the worker around the generation only (not the
metrics); work a method does once per template (fitting DMPs) is shared over its row.  A pair
whose generation fails (a :class:`~hila_lang.core.errors.HilaError`, e.g. on a user's degenerate
ICPs) scores NaN and is counted, never aborts the grid.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.errors import HilaError
from ..core.jit import batch
from ..hierarchy.generate import generate
from ..metrics import names, scores
from ..osila.template import END, START, Template
from . import ablation, baselines, controls
from .ablation import ABLATIONS
from .baselines import BASELINES
from .controls import CONTROLS
from .dataset import Trial
from .protocols import Constraints, constraints

SEGMENTS = (1, 2, 3, 4)
METHODS = ("osila", *CONTROLS, *BASELINES, *ABLATIONS, "hila")


def generator(method: str, path: np.ndarray, options: dict[str, Any]):
    """A function constraints -> path (T, D) for any method but ``hila``, prepared once per template."""
    if method in BASELINES:
        return baselines.generator(method, path, options)
    if method in ABLATIONS:
        return ablation.generator(method, path, options)
    return controls.generator(method, path, options)


def metric_names(dim: int) -> tuple[str, ...]:
    """Names of the scores, in the order of :func:`score`'s values, for D = ``dim`` (the registry,
    :data:`hila_lang.metrics.METRICS`)."""
    return names(dim)


def score(generated: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Every metric of :func:`metric_names` for a generated path against the human one."""
    return scores(generated, target)


@dataclass
class RowResult:
    """Scores of one template row.

    Attributes
    ----------
    row : int
        Template (input) trial index.
    scores : dict of str to ndarray, shape (S, J, M)
        Per method: every metric (:func:`metric_names`) per segment count and task; NaN where
        the pair is not evaluated or failed.
    seconds : dict of str to ndarray, shape (S, J)
        Per method: generation time per path (s).
    failures : dict of str to list of str
        Per method: ``"N=2 exp1/trial01 -> exp3/trial04: message"`` for each failed pair.
    """

    row: int
    scores: dict[str, np.ndarray] = field(default_factory=dict)
    seconds: dict[str, np.ndarray] = field(default_factory=dict)
    failures: dict[str, list[str]] = field(default_factory=dict)


def _hila_generator(template: Trial, options: dict[str, Any]):
    """Constraints -> stitched path of the equal-N sub-templates, via the hierarchical generator."""
    def run(c: Constraints) -> np.ndarray:
        scene = {label: d for label, d, at in zip(c.labels, c.dst, c.at) if at is None}
        icps = {label: s for label, s, at in zip(c.labels, c.src, c.at) if at is None}
        cuts = [0, *(at for at in c.at if at is not None), len(template.path) - 1]
        ends = [d for d, at in zip(c.dst, c.at) if at is not None]
        steps, tasks = [], []
        for k in range(len(cuts) - 1):
            piece = template.path[cuts[k] : cuts[k + 1] + 1]
            marks = {START: piece[0], END: piece[-1]} if c.n > 1 else {}
            steps.append(Template(f"{template.label}.s{k + 1}", piece, {**icps, **marks}, units="px"))
            tasks.append({**scene, END: ends[k]} if k < len(ends) else scene)
        hand = scene.get("hand", c.dst[0])
        return generate(steps, tasks, start=hand if c.n > 1 else None, **options).path

    return run


def evaluate_row(
    trials: list[Trial],
    row: int,
    segments: tuple[int, ...] = SEGMENTS,
    methods: tuple[str, ...] = ("osila",),
    options: dict[str, Any] | None = None,
    protocol: str = "paper",
    tasks: np.ndarray | None = None,
) -> RowResult:
    """Map trial ``row`` onto the tasks for each segment count and method, and score it.

    Parameters
    ----------
    trials : list of Trial
        The dataset (templates and tasks are the same trials).
    row : int
        Index of the template trial.
    segments : tuple of int
        Segment counts N.
    methods : tuple of str
        Any of :data:`METHODS`.
    options : dict, optional
        Options passed to :func:`hila_lang.osila.imitate` (``threshold`` etc.).
    protocol : str
        See :mod:`.protocols`.
    tasks : ndarray of bool, shape (J,), optional
        Which tasks to map onto (default: all).

    Returns
    -------
    RowResult
    """
    options = dict(options or {})
    template = trials[row]
    J = len(trials)
    todo = np.flatnonzero(np.ones(J, bool) if tasks is None else tasks)
    M = len(metric_names(template.path.shape[1]))
    out = RowResult(row)
    gens: dict[str, Any] = {}
    setup_time: dict[str, float] = {}
    for m in methods:
        out.scores[m] = np.full((len(segments), J, M), np.nan)
        out.seconds[m] = np.full((len(segments), J), np.nan)
        out.failures[m] = []
        t0 = time.perf_counter()
        gens[m] = _hila_generator(template, options) if m == "hila" else generator(m, template.path, options)
        setup_time[m] = time.perf_counter() - t0
    per_path = {m: setup_time[m] / max(len(todo) * len(segments), 1) for m in methods}
    for s, n in enumerate(segments):
        for j in todo:
            task = trials[j]
            try:
                c = constraints(template, task, n, protocol)
            except HilaError as exc:
                for m in methods:
                    out.failures[m].append(f"N={n} {template.label} -> {task.label}: {exc.message}")
                continue
            for m in methods:  # every method gets the same constraints object
                t0 = time.perf_counter()
                try:
                    path = gens[m](c)
                except HilaError as exc:
                    out.failures[m].append(f"N={n} {template.label} -> {task.label}: {exc.message}")
                    continue
                out.seconds[m][s, j] = time.perf_counter() - t0 + per_path[m]
                out.scores[m][s, j] = score(path, task.path)
    return out


def evaluate_rows(trials, rows, segments=SEGMENTS, methods=("osila",), options=None, protocol="paper",
                  mask=None) -> list[RowResult]:
    """:func:`evaluate_row` for several rows (one unit of parallel work); ``mask`` (J, J) selects tasks.

    Runs in :func:`hila_lang.core.jit.batch`: thousands of paths repay the compiled kernels' start-up;
    and with one BLAS thread (``threadpoolctl``, a scikit-learn dependency): every matrix here is
    small, and on a loaded machine BLAS threads spinning for each other made a 50 × 50 solve take
    24 ms instead of microseconds (the parallel backends run one row per process anyway).
    """
    # lazy: loads threadpoolctl, which importing this module does not
    from threadpoolctl import threadpool_limits

    with batch(), threadpool_limits(1):
        return [evaluate_row(trials, i, segments, methods, options, protocol, None if mask is None else mask[i])
                for i in rows]
