"""What a method is told about the task: the constraint pairs of one (template, task, N) pair.

Every method of the evaluation — OSILA and every control (:mod:`.controls`) — gets the same
:class:`Constraints`, built once per pair by :func:`constraints`, and nothing else about the
task: the task's human path is used only to score the result.  Three protocols:

``held-out`` (the headline)
    The scene ICPs the template and the task share by name (the hand's start, the object's
    corners, the waypoint area), nothing taken from the path being scored.  One segment: with
    nothing from the scored path there is no segment boundary to add (N = 1 only).

``paper`` (the paper's Experiment A, as a reproduction)
    The shared scene ICPs plus, for N >= 2, the N − 1 inner boundaries of an equal-N split of
    both paths: template boundary point → the TASK PATH's boundary point.  These boundary points
    are points of the very path that is then scored, so a method is handed part of the answer;
    the more segments, the more of it.  That is the paper's protocol; it shows how well a method
    passes through given points, not how well it predicts a movement.

``positions`` (leak-free; the headline for LASA, and on the stand-in)
    Positions only: the points at equal fractions k/N of each path's LENGTH (arc length, the
    nearest sample), template point → task point.  Data with scene ICPs keep them and gain the
    N − 1 inner points; data without (LASA) get k = 0..N (N = 1: the start and the end).  Arc
    length is a property of the drawn shape, not of its timing: a user can point at "a third of
    the way along", and no method is told WHEN the person passed the point.  The scores that
    cannot reward timing (:data:`hila_lang.metrics.METRICS`, ``time_free``) are the headline;
    MSD is shown too, because here no timing is given away.

``fractions`` (LASA; the former protocol, kept as a reproduction)
    The points at time fractions k/N, k = 0..N, of both paths: template point → task point.  N = 1
    gives the start and the end (two pairs); every N adds one inner point.  Like ``paper``, these
    are points of the scored path, and for N >= 2 the pairing says WHEN the person passed them:
    time leaks into MSD, which compares the paths at equal normalised times.

Pairs of trials: for an ICP data set every template with every task (J × J, a trial with itself
included for the paper's Table I); for LASA every ordered pair of different demonstrations of
the same shape (:func:`pair_mask`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from ..osila.segmentation import equal_segments
from .dataset import Trial

PROTOCOLS = ("held-out", "paper", "positions", "fractions")
#: protocols whose constraints never tell a method when the person passed a point (at any N)
LEAK_FREE = ("held-out", "positions")


def leaks_time(protocol: str, n: int) -> bool:
    """True when the constraints of ``protocol`` at N = ``n`` pair points by their time on the
    scored path (``paper`` and ``fractions`` for N >= 2): MSD is then not shown as a result."""
    return protocol not in LEAK_FREE and n > 1


@dataclass(frozen=True)
class Constraints:
    """The constraint pairs of one template/task pair, template point → task point.

    Attributes
    ----------
    src, dst : ndarray, shape (K, D)
        Template points and task points, paired by row, in a fixed order (scene ICPs in the
        template's order, then path points in time order).
    labels : tuple of str
        What each pair is: a scene ICP's name, ``"boundary k/N"`` or ``"t = k/N"``.
    at : tuple of int or None
        For a pair taken from the template PATH (a boundary or time-fraction point), its index
        in the template path; None for a scene ICP.
    n : int
        Segment count N the pairs were built for.
    times : tuple of float or None, or None
        When the task passes each pair's task point, a fraction of the task's duration, for a
        pair taken from the task path at a TIME (``paper`` boundaries, ``fractions``); None for a
        position (a scene ICP, an arc-length point).  OSILA's option ``task_times``: only pairs
        with a time are re-timed.  None: no pair carries one.
    """

    src: np.ndarray
    dst: np.ndarray
    labels: tuple[str, ...]
    at: tuple[int | None, ...]
    n: int
    times: tuple[float | None, ...] | None = None


def fraction_index(length: int, k: int, n: int) -> int:
    """Index of time fraction k/N in a path of ``length`` equally spaced samples."""
    return int(round(k * (length - 1) / n))


def arc_index(path: np.ndarray, k: int, n: int) -> int:
    """Index of the sample nearest arc-length fraction k/N of ``path`` (T, D); k = 0 and k = N are
    the first and last samples."""
    if k <= 0:
        return 0
    if k >= n:
        return len(path) - 1
    s = np.concatenate([[0.0], np.cumsum(np.sqrt((np.diff(path, axis=0) ** 2).sum(1)))])
    return int(np.argmin(np.abs(s - k * s[-1] / n)))


def boundaries(length: int, n: int) -> list[int]:
    """Indices of the N − 1 inner boundaries of an equal-N split of ``length`` points."""
    return [start for start, _ in equal_segments(length, n)[1:]]


def shared_names(template: Trial, task: Trial) -> list[str]:
    """ICP names both trials have, in the template's order."""
    return [name for name in template.icp_names if name in task.icp_names]


def constraints(template: Trial, task: Trial, n: int, protocol: str) -> Constraints:
    """The :class:`Constraints` of mapping ``template`` onto ``task`` with N = ``n`` segments."""
    if protocol not in PROTOCOLS:
        raise InputError(f"unknown protocol {protocol!r}; expected one of {', '.join(PROTOCOLS)}")
    D = template.path.shape[1]
    src: list[np.ndarray] = []
    dst: list[np.ndarray] = []
    labels: list[str] = []
    at: list[int | None] = []
    when: list[float | None] = []  # the task's time of a pair taken from the task path at a time
    if protocol in ("held-out", "paper"):
        if protocol == "held-out" and n != 1:
            raise InputError(f"the held-out protocol has one segment only (nothing from the scored path "
                             f"can bound a segment), got N = {n}")
        for name in shared_names(template, task):
            src.append(template.icps[template.icp_names.index(name)])
            dst.append(task.icps[task.icp_names.index(name)])
            labels.append(name)
            at.append(None)
            when.append(None)
        if protocol == "paper" and n > 1:
            for k, (a, b) in enumerate(zip(boundaries(len(template.path), n), boundaries(len(task.path), n)), 1):
                src.append(template.path[a])
                dst.append(task.path[b])
                labels.append(f"boundary {k}/{n}")
                at.append(a)
                when.append(b / (len(task.path) - 1))
    elif protocol == "positions":
        for name in shared_names(template, task):
            src.append(template.icps[template.icp_names.index(name)])
            dst.append(task.icps[task.icp_names.index(name)])
            labels.append(name)
            at.append(None)
            when.append(None)
        ends = range(1, n) if src else range(n + 1)  # scene data keep their ICPs and gain inner points
        for k in ends:
            a, b = arc_index(template.path, k, n), arc_index(task.path, k, n)
            src.append(template.path[a])
            dst.append(task.path[b])
            labels.append(f"s = {k}/{n}")
            at.append(a)
            when.append(None)  # a position along the drawn shape: when it was passed is not given
    else:
        for k in range(n + 1):
            a, b = fraction_index(len(template.path), k, n), fraction_index(len(task.path), k, n)
            src.append(template.path[a])
            dst.append(task.path[b])
            labels.append(f"t = {k}/{n}")
            at.append(a)
            when.append(b / max(len(task.path) - 1, 1))
    if not src:
        raise InputError(f"{template.label} and {task.label} share no ICP name; nothing to map with")
    times = tuple(when) if any(w is not None for w in when) else None
    return Constraints(np.array(src).reshape(-1, D), np.array(dst).reshape(-1, D), tuple(labels), tuple(at), n, times)


def segments_for(protocol: str) -> tuple[int, ...]:
    """Segment counts N evaluated under ``protocol``."""
    return (1,) if protocol == "held-out" else (1, 2, 3, 4)


def pair_mask(trials: list[Trial], within_setup_only: bool) -> np.ndarray:
    """Which (template, task) pairs are evaluated, shape (J, J) of bool.

    ``within_setup_only``: ordered pairs of DIFFERENT trials of the same set-up (LASA: the same
    shape); otherwise every pair, a trial with itself included.
    """
    J = len(trials)
    if not within_setup_only:
        return np.ones((J, J), bool)
    setup = np.array([t.setup for t in trials])
    return (setup[:, None] == setup[None, :]) & ~np.eye(J, dtype=bool)
