"""OSILA: one-shot imitation of a template path in a new scene (docs/design.md §2.2).

:func:`imitate` is the contract: re-estimate which part of the template passes an ICP that lies
on its path and carries the task's time (:mod:`.timing`), warp the template with a thin plate
spline fitted on paired ICPs (:mod:`.tps`, with similarity/translation fallbacks in
:mod:`.fallback`) or, where the pairs hold both ends of the path, bend the path itself
(:mod:`.pathwarp`), choose the
minimum-energy route through a ball of candidate waypoints around every mapped point, as large
as the template's measurement noise (:mod:`.noise`, :mod:`.candidates`, :mod:`.route`), then
adjust the plan until forced waypoints and obstacles are satisfied (:mod:`.adjust`).  :func:`imitate_detailed` returns the same route with its
diagnostics.

One line each:

- ``pairs``         ICP pairs by name (:class:`Pairs`): what a step binds, the arrays OSILA takes
- ``template``      templates: a demonstrated path, named ICPs, tagged sub-templates; their YAML
- ``demofile``      demonstration files: a path as CSV, its scene ICPs as YAML
- ``segmentation``  a demonstration cut into ordered, tagged phases (k-means or equal-N)
- ``motion``        human-like motion profiles shared by the demonstration generators
- ``timing``        which part of the template passes an ICP that lies on its path
- ``robust``        many noisy ICP pairs: outliers rejected before the warp
- ``tps``           the thin plate spline warp fitted on paired ICPs
- ``tps_loops``     the TPS's compiled loops: distances, rank, the choice systems
- ``fallback``      similarity and translation warps when TPS cannot be trusted
- ``pathwarp``      the path bent along itself (Laplacian coordinates kept) where pairs hold its ends
- ``saddle``        the warp's two systems kept as Cholesky factors: Rippa's leave-one-out errors, solves
- ``noise``         the template's measurement noise: the candidates' radius, the TPS's amplification limit
- ``candidates``    a ball of candidate waypoints around every mapped point
- ``route``         the minimum-energy route through the candidates
- ``adjust``        plan adjustment until forced waypoints and obstacles hold
- ``bordered``      the warp's inverses grown from round to round while the pairs only grow
- ``warm``          every kernel compiled into numba's cache at once (the first run's background process)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.validation import check_int, check_path, check_points, check_positive
from .adjust import STRETCH, OsilaResult, adjust
from .pairs import Pairs
from .robust import METHODS
from .timing import TIMING
from .tps import Warp, fit_warp

__all__ = ["imitate", "imitate_detailed", "OsilaResult", "Warp", "fit_warp", "OPTIONS", "PER_STEP", "Pairs",
           "obstacle_spheres"]

#: option name -> default (see :func:`imitate`)
OPTIONS: dict[str, Any] = {
    "threshold": None,
    "rounds": 10,
    "smoothing": 0.0,
    "seed": 0,
    "distortion": 0.0,
    "margin": 0.0,
    "shells": 2,
    "directions": None,
    "pin": (),
    "timing": TIMING,
    "stretch": STRETCH,
    "reject": "auto",
    "task_times": None,
    "precision": None,
}
#: the options of one call's own pairs and path (a step's), not of a whole run: ``--set`` and a
#: task file cannot give them
PER_STEP = ("pin", "task_times")


def obstacle_spheres(obstacles: Any, dim: int) -> np.ndarray:
    """Spheres as an array (O, D+1): centre then radius; accepts dicts {centre|center, radius}.
    The one reader of obstacle specs (``imitate``'s, and a step's on a drawing surface)."""
    if obstacles is None:
        return np.zeros((0, dim + 1))
    if isinstance(obstacles, (list, tuple)) and obstacles and all(isinstance(o, dict) for o in obstacles):
        rows = []
        for i, o in enumerate(obstacles):
            centre = o.get("centre", o.get("center"))
            unknown = set(o) - {"centre", "center", "radius", "name"}
            if centre is None or "radius" not in o or unknown:
                raise InputError(
                    f"expected obstacles[{i}] as {{centre: [..{dim} numbers..], radius: r}}, got keys {sorted(o)}"
                )
            c = check_points(centre, dim, f"obstacles[{i}].centre")[0]
            rows.append(np.append(c, check_positive(o["radius"], f"obstacles[{i}].radius")))
        return np.array(rows)
    arr = check_points(obstacles, dim + 1, "obstacles", allow_empty=True, width=f"(D = {dim} centre coordinates, then the radius)")
    if (arr[:, -1] <= 0).any():
        i = int(np.argmax(arr[:, -1] <= 0))
        raise InputError(f"expected obstacle radii > 0, got {arr[i, -1]} in row {i}")
    return arr


def _pin(pin: Any, T: int, D: int) -> tuple[tuple[int, np.ndarray | None], ...]:
    """Option ``pin`` as ((stamp in [0, T), point (D,) or None), ...), later entries winning."""
    if isinstance(pin, dict):
        items = list(pin.items())
    else:
        try:
            items = [(i, None) for i in pin]
        except TypeError:
            items = None
    if items is None:
        raise InputError(f"expected option 'pin' as a list of stamp indices or a mapping stamp -> point, got {pin!r}")
    out: dict[int, np.ndarray | None] = {}
    for i, point in items:
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)):
            raise InputError(f"expected 'pin' stamps as integers, got {i!r}")
        if not -T <= i < T:
            raise InputError(f"expected 'pin' stamps in [-{T}, {T - 1}] for a path of {T} points, got {i}")
        out[int(i) % T] = None if point is None else check_points(point, D, f"pin point for stamp {i}")[0]
    return tuple(out.items())


def _task_times(value: Any, K: int) -> np.ndarray | None:
    """Option ``task_times`` as (K,) fractions in [0, 1], NaN where not known; None if none given."""
    if value is None:
        return None
    try:
        items = list(value)
    except TypeError:
        items = None
    if items is None or len(items) != K:
        raise InputError(f"expected option 'task_times' as one entry per ICP pair ({K}), each a fraction of the "
                         f"task's duration in [0, 1] or None, got {value!r}")
    out = np.full(K, np.nan)
    for k, v in enumerate(items):
        if v is None or (isinstance(v, float) and np.isnan(v)):
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not 0.0 <= float(v) <= 1.0:
            raise InputError(f"expected 'task_times' entries as fractions of the task's duration in [0, 1] or None, "
                             f"got {v!r} for pair {k}")
        out[k] = float(v)
    return out if np.isfinite(out).any() else None


def _reject(value: Any) -> str:
    if value not in METHODS:
        raise InputError(f"expected option 'reject' as one of {', '.join(METHODS)}, got {value!r}")
    return value


def imitate_detailed(
    path: Any,
    template_icps: Any,
    task_icps: Any,
    *,
    forced: Any = None,
    obstacles: Any = None,
    **options: Any,
) -> OsilaResult:
    """As :func:`imitate`, returning an :class:`~hila_lang.osila.adjust.OsilaResult`."""
    path = check_path(path, "path")
    D = path.shape[1]
    src = check_points(template_icps, D, "template_icps")
    dst = check_points(task_icps, D, "task_icps")
    if src.shape[0] != dst.shape[0]:
        raise InputError(
            f"expected template_icps and task_icps paired by row, got K = {src.shape[0]} and K = {dst.shape[0]}"
        )
    forced_arr = (
        np.zeros((0, D)) if forced is None else check_points(forced, D, "forced waypoints", allow_empty=True)
    )
    obst = obstacle_spheres(obstacles, D)
    unknown = sorted(set(options) - set(OPTIONS))
    if unknown:
        raise InputError(f"unknown option {unknown[0]!r}; expected one of {', '.join(OPTIONS)}")
    opts = {**OPTIONS, **options}
    threshold = None if opts["threshold"] is None else check_positive(opts["threshold"], "threshold", allow_zero=True)
    directions = None if opts["directions"] is None else check_int(opts["directions"], "directions", minimum=1)
    check_int(opts["seed"], "seed")
    pin = _pin(opts["pin"], path.shape[0], D)
    return adjust(
        path,
        src,
        dst,
        forced_arr,
        obst,
        threshold=threshold,
        rounds=check_int(opts["rounds"], "rounds", minimum=1),
        smoothing="auto" if opts["smoothing"] == "auto" else check_positive(opts["smoothing"], "smoothing",
                                                                             allow_zero=True),
        distortion=check_positive(opts["distortion"], "distortion", allow_zero=True),
        margin=check_positive(opts["margin"], "margin", allow_zero=True),
        shells=check_int(opts["shells"], "shells", minimum=0),
        directions=directions,
        pin=pin,
        timing=check_positive(opts["timing"], "timing", allow_zero=True),
        stretch=check_positive(opts["stretch"], "stretch"),
        reject=_reject(opts["reject"]),
        seed=int(opts["seed"]),
        task_times=_task_times(opts["task_times"], len(src)),
        precision=None if opts["precision"] is None else check_positive(opts["precision"], "precision", allow_zero=True),
    )


def imitate(
    path: Any,
    template_icps: Any,
    task_icps: Any,
    *,
    forced: Any = None,
    obstacles: Any = None,
    **options: Any,
) -> np.ndarray:
    """Imitate a template path in a task scene.

    Parameters
    ----------
    path : array_like, shape (T, D)
        Template path, D in {2, 3}, any length unit (metres for the robot).
    template_icps, task_icps : array_like, shape (K, D)
        ICPs of the demonstration and of the task scene, paired by row, K >= 1.  K < D+1 or
        degenerate ICPs (collinear in 2-D, coplanar in 3-D) fall back to a similarity transform
        (K >= 2) or a translation (K = 1); template ICPs that coincide are merged.
    forced : array_like, shape (F, D), optional
        Waypoints the route must pass within ``threshold`` (in any order).
    obstacles : array_like, shape (O, D+1), or list of dict, optional
        Spheres: rows ``[centre..., radius]`` or dicts ``{"centre": [...], "radius": r}``.  No
        route waypoint lies closer than ``radius + margin`` to a centre.
    **options
        threshold : float, default 2 σ of the mapped path's position noise
            Radius of the candidate ball (task units); every waypoint stays within it of its
            mapped point, the first and last waypoints are the mapped start and goal, and an
            ICP whose template point is a waypoint is met exactly there.  0 returns the warped
            path itself.  The default is measured on the path (:mod:`.noise`): the route irons
            out the template's noise and keeps its shape; on a clean recording it is nearly 0.
        task_times : sequence of float or None, default None
            When the task passes each ICP pair, a fraction of its duration in [0, 1] (None: not
            known).  A pair whose template point lies on the template path and that carries a
            time agreeing with the template's (:func:`.timing.timed_stamps`) is re-timed (below);
            without times no pair is: a position says where the task passes, not when.
        timing : float, default 0.03
            Prior spread (a fraction of the template's duration) of when the task passes an ICP
            that lies on the template path and carries a task time: such a pair's template stamp
            is re-estimated and the template re-timed so that the pair is still met exactly at
            its own stamp (:mod:`.timing`).  0 keeps the template's timing.
        rounds : int, default 10
            Maximum plan-adjustment rounds.
        smoothing : float or "auto", default 0
            TPS regulariser λ (unit-free, template normalised to unit extent); 0 = exact.
            ``"auto"``: chosen by cross-validation on the kept pairs' leave-one-out errors (for
            noisy pairs, 10 or more; :func:`.robust.choose_smoothing`), reported in
            :attr:`OsilaResult.pairs`.
        distortion : float, default 0
            Weight of Σ|q_t - f(p_t)|² added to the route energy Σ|q_{t+1} - q_t|².
        margin : float, default 0
            Extra clearance around obstacles (task units).
        shells, directions : int, default 2 and 8 (2-D) / 14 (3-D)
            Candidate set: centre + shells × directions points (:mod:`.candidates`).
        pin : sequence of int, or mapping int -> point, default ()
            Stamps (negative = from the end) whose waypoint is fixed.  A mapping pins each
            stamp to a point, met exactly (bit for bit) and smoothly: the pair (template point
            at the stamp -> point) is interpolated exactly by the warp, after and over any ICP
            at the same template point, e.g. ``{0: hand, -1: goal}`` to start where the hand
            is and end on a bound target.  A sequence, e.g. ``(0,)``, fixes each stamp at its
            mapped point (no candidate ball there).
        precision : float, default the template's measured position noise
            How precisely the ICPs are located (task units).  The TPS is kept only while its
            amplification of errors of this size on the path is no larger than the deformation
            the pairs show beyond a similarity (:func:`.noise.amplification_limit`); give it when
            the ICPs are placed less precisely than the template was measured (points placed
            by hand on a clean drawing).
        stretch : float, default 5
            A repair bends the route between the held targets (the first and last waypoints,
            and the waypoint nearest each ICP the template passes through), which keep the
            places the first route gave them: a via never moves the goal.  A forced waypoint
            that would make the route between its two targets more than ``stretch`` times as
            long is refused (:class:`ConstraintError` naming it and the target).
        reject : {"auto", "none", "loo", "lmeds"}, default "auto"
            Outlier rejection among the ICP pairs, with at least 10 pairs (:mod:`.robust`):
            rejected pairs are left out of the warp; :attr:`OsilaResult.pairs` says how many
            were matched, kept and rejected, and the kept pairs' leave-one-out residual.
        seed : int, default 0
            Seeds the random sets of ``reject="lmeds"`` (OSILA makes no other random choice).

    Returns
    -------
    ndarray, shape (T, D)
        The generated route.

    Raises
    ------
    InputError
        Bad shapes, NaN/inf, an empty path, K = 0, K mismatch, unknown or bad options.
    ConstraintError
        The constraints contradict each other or could not be met within ``rounds``.
    """
    return imitate_detailed(path, template_icps, task_icps, forced=forced, obstacles=obstacles, **options).path
