"""The trace: what each step did (:class:`TraceEntry`), the newest entries kept
(:class:`Trace`), and how values read in it (:func:`fmt_point`, :func:`fmt_value`, :func:`met_text`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.bounded import BoundedLog
from ..language import ast as A
from ..language.limits import TRACE_KEEP


@dataclass
class TraceEntry:
    """What one step did."""

    step: int
    state: str
    kind: str
    line: int
    text: str
    next: str | None
    path: np.ndarray | None = None
    executed: np.ndarray | None = None
    icps: dict[str, np.ndarray] = field(default_factory=dict)
    pen_down: bool | None = None
    value: Any = None
    #: the HILA step of a run state (:class:`hila_lang.hierarchy.step.Step`: OSILA's result, constraints)
    step_result: Any = None
    error: str | None = None  # why the step failed or stopped (its text says so too)
    #: a streamed run's re-plans (:class:`hila_lang.engine.tracking.Replan`), None when not streamed
    replans: list | None = None

    def __str__(self) -> str:
        where = f"line {self.line}" if self.line else "-"
        return f"{self.step:>3}  {self.state}  [{where}]  {self.text}"


class Trace(BoundedLog):
    """The trace: the newest entries (:class:`~hila_lang.core.bounded.BoundedLog`), so a run of any
    length keeps memory flat.  ``total`` (= ``len()``) counts every entry recorded since the
    reset (the step number of the last one); ``kinds`` how many of each kind."""

    def __init__(self, keep: int = TRACE_KEEP) -> None:
        super().__init__(keep)
        self.kinds: dict[str, int] = {}

    @property
    def total(self) -> int:
        return len(self)

    def record(self, entry: TraceEntry) -> None:
        self.append(entry)
        self.kinds[entry.kind] = self.kinds.get(entry.kind, 0) + 1

    def __delitem__(self, index) -> None:
        for entry in self.removed_after(index.start or 0) if isinstance(index, slice) else ():
            self.kinds[entry.kind] -= 1
        super().__delitem__(index)


def fmt_point(p) -> str:
    return "(" + ", ".join(f"{(0.0 if abs(v) < 5e-4 else v):.3f}" for v in np.asarray(p, float)) + ")"


def fmt_value(v) -> str:
    if isinstance(v, np.ndarray):
        return fmt_point(v)
    if isinstance(v, bool) or v is None:
        return {True: "true", False: "false", None: "none"}[v]
    if isinstance(v, float):
        return A.number_text(round(v, 6))
    if isinstance(v, str):
        return f'"{v}"'
    return repr(v)


def met_text(step, executed=None) -> str:
    """How a run met its constraints, for the trace: ``; via w at 5:9 met at 0.4 mm``, measured
    on the path the hand took (``executed``) when the back end reports it, else on the plan."""
    parts = []
    for c, value in step.met(executed):
        if c.radius is None:
            parts.append(f"{c.name} met at {value * 1000:.1f} mm")
        else:
            parts.append(f"{c.name} cleared by {value * 1000:.1f} mm")
    return "".join(f"; {p}" for p in parts)
