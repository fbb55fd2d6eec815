"""OSILA with one part taken away: what does each part add?

``osila-noroute``
    No minimum-energy route: the warped template itself (OSILA's option ``threshold = 0``).
``osila-noretime``
    No re-timing of the on-path pairs (option ``timing = 0``).
``osila-noadjust``
    No plan adjustment: the first route, never checked or repaired (:func:`variant`).  Plan
    adjustment acts on forced waypoints and obstacles only; the evaluation has neither, so this
    row equals ``osila`` on every pair, by construction — printed so the table says so.
``osila-tps``
    OSILA with its warp always the thin plate spline (the paper's warp; no similarity fallback,
    no amplification check); re-timing and route as OSILA.
``osila-similarity``
    OSILA with its warp always the least-squares similarity (the ``similarity`` control's
    placement); re-timing and route as OSILA.
``osila-nopath``
    OSILA without its path warp (:mod:`hila_lang.osila.pathwarp`): the spatial choice between
    the TPS and the similarity fallback only, as before the path warp was added.
``osila-retimeall``
    OSILA re-timing every pair on the template path as if it carried the task's time, whether
    the constraints give one or not (as before re-timing asked the pairs): what the re-timing
    gate (:func:`hila_lang.osila.timing.timed_stamps`) saves under a protocol without times.
``osila-fixedlimit``
    OSILA with the TPS's amplification limit fixed at :data:`FORMER_LIMIT` (6 in 2-D, 8 in 3-D),
    the constant it had before the limit followed the data
    (:func:`hila_lang.osila.noise.amplification_limit`).

``osila-noretime`` runs OSILA itself with that option; the others run :func:`variant` (OSILA's
parts without the plan-adjustment loop, which the evaluation never enters), so that they share
one re-timing and one warp per pair.  OSILA has no option that fixes its warp, and its
package is not changed for an ablation, so the warp ablations are composed here from OSILA's public
parts in OSILA's order (:func:`variant`): re-time (:func:`~hila_lang.osila.timing.retime`), warp,
a candidate ball of the default threshold around every mapped point
(:func:`~hila_lang.osila.noise.default_threshold`, :func:`~hila_lang.osila.candidates.ball_offsets`),
the minimum-energy route (:func:`~hila_lang.osila.route.min_energy_route`) with the ends and the
on-path pairs pinned.  With OSILA's own warp choice (``warp="auto"``) it returns exactly what
:func:`hila_lang.osila.imitate` returns on the evaluation's constraints (no forced waypoints, no
obstacles): the tests check that, so the two rows differ from ``osila`` by the warp only.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..osila import OPTIONS
from ..osila.candidates import ball_offsets
from ..osila.noise import default_threshold
from ..osila.pathwarp import choose_warp
from ..osila.route import min_energy_route
from ..osila.tps import fit_warp
from .baselines import retime_once
from .controls import _apply, similarity
from .protocols import Constraints

ABLATIONS = ("osila-noroute", "osila-noretime", "osila-noadjust", "osila-tps", "osila-similarity", "osila-nopath",
             "osila-retimeall", "osila-fixedlimit")
#: the TPS's amplification limit before it followed the data, per dimension D (``bench/warp.py``
#: measured it on synthetic pairs whose ICPs are located to 1 % of the extent)
FORMER_LIMIT = {2: 6.0, 3: 8.0}
#: the ablations that are OSILA options (``osila-noretime`` runs through :func:`hila_lang.osila.imitate`;
#: the others through :func:`variant`, which is OSILA without the plan-adjustment loop, so they share
#: one re-timing and one warp per pair)
OPTION_ABLATIONS = {"osila-noroute": {"threshold": 0.0}, "osila-noretime": {"timing": 0.0},
                    "osila-noadjust": {}}


def variant(path: np.ndarray, c: Constraints, warp: str = "auto", options: dict[str, Any] | None = None,
            retime_all: bool = False) -> np.ndarray:
    """OSILA on ``c`` with the warp ``"auto"`` (OSILA's choice), ``"tps"``, ``"similarity"``,
    ``"spatial"`` (OSILA's choice without the path warp) or ``"fixedlimit"`` (OSILA's choice with
    the amplification limit :data:`FORMER_LIMIT`).

    ``options``: OSILA's ``threshold`` (None: its default), ``timing``, ``shells``, ``directions``.
    ``retime_all``: every pair on the template path carries its template point's own time, so all
    of them are re-timed (:func:`all_timed`).
    """
    opts = {**OPTIONS, **(options or {})}
    T, D = path.shape
    moved = retime_once(path, c, opts["timing"], all_timed(path, c) if retime_all else None)
    P, src = moved.path, moved.src
    chosen = moved.warp if moved.warp is not None else _warp_once(moved, c)
    if warp == "spatial":
        chosen = fit_warp(src, c.dst, on=P)
    elif warp == "fixedlimit":
        chosen = choose_warp(src, c.dst, on=P, max_amplification=FORMER_LIMIT[D])
    met = {t: chosen.dst[k] for t, k in chosen.at.items()}  # on-path pairs: met exactly at their stamp
    if warp in ("auto", "spatial", "fixedlimit"):
        mapped = chosen.mapped
    elif warp == "tps":
        mapped = fit_warp(src, c.dst)(P)  # the bare warp (a fallback only when a TPS cannot be fitted)
    elif warp == "similarity":
        mapped = _apply(similarity(Constraints(src, c.dst, c.labels, c.at, c.n)), P)
        met = {}  # a rigid placement meets no pair exactly: the stamps are pinned at their mapped points
    else:
        raise ValueError(f"unknown warp {warp!r}")
    threshold = default_threshold(mapped) if opts["threshold"] is None else float(opts["threshold"])
    offsets = ball_offsets(D, threshold, opts["shells"], opts["directions"])
    pinned = sorted({0, T - 1, *chosen.at})
    choice, _ = min_energy_route(mapped, offsets, 0.0, None, pinned=pinned)
    route = mapped + offsets[choice]
    for t, q in met.items():
        route[t] = q
    return route


def all_timed(path: np.ndarray, c: Constraints) -> tuple[float | None, ...]:
    """Task times that say every pair on the template path is passed at its template point's own
    time (a fraction of the duration): OSILA's re-timing then takes each of them as timed."""
    T = len(path)
    return tuple(None if a is None else a / max(T - 1, 1) for a in c.at)


_last: list = []  # the last warp fitted: (re-timing, constraints, warp)


def _warp_once(moved, c: Constraints):
    """OSILA's warp of a re-timed pair, fitted once for the ablation rows that share it."""
    if not (_last and _last[0] is moved and _last[1] is c):
        _last[:] = [moved, c, choose_warp(moved.src, c.dst, on=moved.path)]
    return _last[2]


def generator(method: str, path: np.ndarray, options: dict[str, Any]) -> Callable[[Constraints], np.ndarray]:
    """A function constraints -> path (T, D) for one of :data:`ABLATIONS`, prepared once per template."""
    if method == "osila-noretime":
        # lazy: only this branch needs it
        from ..osila import imitate

        opts = {**options, **OPTION_ABLATIONS[method]}
        return lambda c: imitate(path, c.src, c.dst, task_times=c.times, **opts)
    if method in OPTION_ABLATIONS:
        opts = {**options, **OPTION_ABLATIONS[method]}
        return lambda c: variant(path, c, "auto", opts)
    if method == "osila-retimeall":
        return lambda c: variant(path, c, "auto", options, retime_all=True)
    warp = {"osila-nopath": "spatial"}.get(method, method.removeprefix("osila-"))
    return lambda c: variant(path, c, warp, options)
