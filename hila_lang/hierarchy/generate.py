"""Sequences of HILA steps stitched together (:func:`generate`), named by :func:`resolve`.

A new task is a sequence of stored templates and sub-templates (a hierarchy is flattened into
its sequence of leaves first, e.g. by the language's FSM).  :func:`generate` runs OSILA on each
step in turn:

- the step's template ICPs are bound by name to the task ICPs (one mapping for all steps, or one
  mapping per step); every scene ICP of the template must be bound — a missing name is an
  :class:`~hila_lang.core.errors.InputError` that lists what the template has and the task gives;
- the boundary ICPs a sub-template carries (``"start"``, ``"end"``, see
  :meth:`Template.sub <hila_lang.osila.template.Template.sub>`) are bound when known: ``"start"`` to
  where the hand is (``start`` for the first step, the previous step's last point after that)
  and pinned there exactly; ``"end"`` only when the task mapping gives ``"end"``; unbound
  boundary ICPs are dropped;
- the pieces are stitched into one path; a piece's first point, equal to the previous piece's
  last one, is not repeated.

The paper's example: demonstrate A-B-C once, segment it, then
``generate(resolve({"demo": t}, ["C", "B", "A", "A", "C"]), t.icps)`` — no new demonstration.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..core.errors import InputError
from ..core.validation import check_points
from ..osila.template import START, Template
from .step import hila_step


@dataclass
class Piece:
    """One generated step inside the stitched path.

    Attributes
    ----------
    tag : str
        The step's segment tag (or template name when unsegmented).
    template : str
        Name of the template imitated.
    start, stop : int
        Index range ``[start, stop)`` of this piece in the stitched path.
    contact : bool
        The step touches the surface (copied from the template's segment).
    warp : str
        Warp kind used (``"tps"``, ``"similarity"``, ``"translation"``).
    threshold : float
        Distortion threshold used (task units).
    rounds : int
        Plan-adjustment rounds run.
    added : int
        Constraint pairs added by plan adjustment.
    """

    tag: str
    template: str
    start: int
    stop: int
    contact: bool
    warp: str
    threshold: float = 0.0
    rounds: int = 1
    added: int = 0


@dataclass
class Generated:
    """A stitched multi-step path.

    Attributes
    ----------
    path : ndarray, shape (N, D)
    pieces : list[Piece]
        In order, contiguous, covering the path.
    times : ndarray, shape (N,), optional
        Seconds from the first point, when every step's template has times.
    """

    path: np.ndarray
    pieces: list[Piece] = field(default_factory=list)
    times: np.ndarray | None = None

    def tags(self) -> list[str]:
        """Tags of the pieces in order."""
        return [p.tag for p in self.pieces]


def resolve(library: Mapping[str, Template], names: Sequence[str]) -> list[Template]:
    """Turn step names into templates.

    A name is ``"TEMPLATE.TAG"`` (a sub-template), ``"TAG"`` (a sub-template whose tag is unique
    across the library) or ``"TEMPLATE"`` (a whole template).  Unknown or ambiguous names raise
    :class:`InputError` listing the choices.
    """
    out = []
    choices = sorted([*library, *(f"{n}.{tag}" for n, t in library.items() for tag in t.tags())])
    for name in names:
        tpl, dot, tag = name.rpartition(".")
        if dot and tpl in library and tag in library[tpl].tags():
            out.append(library[tpl].sub(tag))
            continue
        owners = [n for n, t in library.items() if name in t.tags()]
        if len(owners) == 1:
            out.append(library[owners[0]].sub(name))
        elif len(owners) > 1:
            raise InputError(f"step {name!r} is ambiguous: tag of {', '.join(owners)}; write TEMPLATE.{name}")
        elif name in library:
            out.append(library[name])
        else:
            raise InputError(f"unknown step {name!r}; expected one of: {', '.join(choices)}")
    return out



def _extent(path: np.ndarray) -> float:
    """Bounding-box diagonal of ``path`` (at least 1, so a point-like path keeps a tolerance)."""
    return max(float(np.linalg.norm(np.ptp(path, axis=0))), 1.0)


def generate(
    steps: Sequence[Template],
    task_icps: Mapping[str, Any] | Sequence[Mapping[str, Any]],
    *,
    start: Any = None,
    forced: Mapping[int, Any] | None = None,
    obstacles: Any = None,
    **options: Any,
) -> Generated:
    """Imitate each step against the task ICPs and stitch the pieces (see the module docstring).

    Parameters
    ----------
    steps : sequence of Template
        Usually sub-templates (``Template.sub``); see :func:`resolve`.
    task_icps : mapping name -> (D,), or one such mapping per step
        Task-scene ICPs (metres); ``"end"`` binds a step's end point.
    start : array_like, shape (D,), optional
        Where the hand is before the first step (binds its ``"start"`` ICP).
    forced : mapping step index -> (F, D), optional
        Forced waypoints per step.
    obstacles : optional
        Spheres applied to every step (as in :func:`hila_lang.osila.imitate`).
    **options
        Passed to :func:`hila_lang.osila.imitate` for every step.

    Returns
    -------
    Generated
    """
    if not steps:
        raise InputError("expected at least one step, got an empty sequence")
    if isinstance(task_icps, Mapping):
        tasks = [task_icps] * len(steps)
    else:
        tasks = list(task_icps)
        if len(tasks) != len(steps):
            raise InputError(f"expected one task ICP mapping per step ({len(steps)}), got {len(tasks)}")
    D = steps[0].dim
    if any(s.dim != D for s in steps):
        raise InputError(f"expected every step in D = {D}, got {[s.dim for s in steps]}")
    hand = None if start is None else check_points(start, D, "start")[0]
    forced = forced or {}
    options = {k: v for k, v in options.items() if k != "pin"}  # the step pins a bound start itself
    parts: list[np.ndarray] = []
    pieces: list[Piece] = []
    clocks: list[np.ndarray] | None = [] if all(s.times is not None for s in steps) else None
    clock = 0.0
    for i, (step, task) in enumerate(zip(steps, tasks)):
        if hand is not None:  # the hand, once known, binds "start" (a task's own "start" does not)
            task = {k: v for k, v in task.items() if k != START}
        try:
            done = hila_step(step, task, hand, forced=forced.get(i), obstacles=obstacles, **options)
        except InputError as exc:
            exc.message = f"step {i} ({step.name}): {exc.message}"
            exc.args = (exc.message,)
            raise
        res, pinned = done.result, done.start_bound
        piece, skip = done.path, 0
        # A pinned start is the hand, i.e. the previous piece's last point: keep that joint once.
        # (The warp meets it only to rounding, or to the merge of coincident ICPs.)
        if parts and (pinned or np.allclose(piece[0], parts[-1][-1], rtol=0, atol=1e-9 * _extent(piece))):
            piece, skip = piece[1:], 1
        if clocks is not None:
            rel = step.times - step.times[0]
            if parts and not skip:  # no shared joint point: one sampling step between pieces
                rel = rel + (float(np.median(np.diff(step.times))) if len(rel) > 1 else 0.0)
            rel = rel[skip:] + clock
            clocks.append(rel)
            clock = float(rel[-1]) if len(rel) else clock
        seg = step.segments[0] if len(step.segments) == 1 else None
        tag = seg.tag if seg is not None else step.name
        start_idx = sum(len(p) for p in parts)
        pieces.append(
            Piece(tag, step.name, start_idx, start_idx + len(piece), bool(seg and seg.contact), res.warp.kind,
                  res.threshold, res.rounds, len(res.added))
        )
        parts.append(piece)
        hand = done.path[-1]
    path = np.vstack(parts)
    times = None if clocks is None else np.concatenate(clocks)
    return Generated(path, pieces, times)
