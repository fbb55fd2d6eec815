"""A library of templates to recognise: every ``*.yaml`` template in a folder, split into parts.

A *part* (:class:`Entry`) is what recognition looks for: each tagged segment of a template (its
sub-template, ``circle.draw``), or the whole path of an unsegmented template (tag ``None``).
A segmented template is found as its consecutive parts, so a whole demonstrated circle comes out
as ``reach``, ``draw``, ``retract`` and each is reported on its own.

Errors are located: a missing folder, a folder with no templates, or a template that does not
load (the file and the field are named by :func:`hila_lang.osila.template.load_template`) stop
before anything is written.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..osila.template import Template, load_template
from .shape import arc_length, arc_resample, heading, smooth

#: points per library part after arc-length re-sampling (the verification resolution)
REFERENCE_POINTS = 64


@dataclass
class Entry:
    """One searchable library part.

    Attributes
    ----------
    template : str
        Template name.
    tag : str or None
        Segment tag; ``None`` for an unsegmented template.
    points : ndarray, shape (REFERENCE_POINTS, D)
        The part re-sampled at equal arc-length steps.
    length : float
        Its arc length, template units.
    source : str
        The file it came from ('' for an in-memory template).
    contact : bool
        The segment's contact flag.
    """

    template: str
    tag: str | None
    points: np.ndarray
    length: float
    source: str = ""
    contact: bool = False
    _signals: dict = field(default_factory=dict, repr=False, compare=False)

    def signal(self, n: int) -> np.ndarray:
        """The search signal (:func:`.shape.heading`) of the part re-sampled to ``n`` points (cached)."""
        if n not in self._signals:
            self._signals[n] = heading(arc_resample(self.points, n))
        return self._signals[n]

    @property
    def name(self) -> str:
        return self.template if self.tag is None else f"{self.template}.{self.tag}"

    @property
    def dim(self) -> int:
        return int(self.points.shape[1])


def entries_of(template: Template, source: str = "") -> list[Entry]:
    """The searchable parts of ``template`` (parts shorter than 4 points or not moving are left out)."""
    spans = [(s.tag, s.start, s.stop, s.contact) for s in template.segments] or [(None, 0, len(template.path), False)]
    out = []
    for tag, a, b, contact in spans:
        part = smooth(template.path[a:b])
        s = arc_length(part)
        if b - a < 4 or s[-1] <= 0:
            continue
        out.append(Entry(template.name, tag, arc_resample(part, REFERENCE_POINTS, s), float(s[-1]), source, bool(contact)))
    return out


def load_library(folder: str | os.PathLike) -> tuple[list[Template], list[Entry]]:
    """Every template in ``folder`` (``*.yaml``, not recursive, sorted) and their parts.

    Raises
    ------
    InputError
        The folder is missing or not a folder, holds no template, or a template does not load
        (the error names that file).
    """
    where = Path(folder)
    if not where.exists():
        raise InputError("library folder does not exist", file=str(where), hint="--library DIR: a folder of template YAML files")
    if not where.is_dir():
        raise InputError("expected a folder of templates, got a file", file=str(where))
    files = sorted(p for p in where.glob("*.yaml") if p.is_file()) + sorted(p for p in where.glob("*.yml") if p.is_file())
    if not files:
        raise InputError("library folder holds no templates (*.yaml)", file=str(where),
                         hint="make one with 'hila learn ... -o DIR/NAME.yaml'")
    templates, entries = [], []
    for f in files:
        template = load_template(f)  # a broken template raises, naming the file and field
        templates.append(template)
        entries.extend(entries_of(template, str(f)))
    names = [t.name for t in templates]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        clash = [str(f) for f, t in zip(files, templates) if t.name == dup]
        raise InputError(f"two templates are named {dup!r} ({', '.join(clash)}); template names must be unique in a library",
                         file=clash[1])
    return templates, entries
