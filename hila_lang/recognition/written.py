"""What ``hila learn --library`` writes: the recognised template and the JSON report.

**The written template** (design, issue 26 item 1).  The path, times and ICPs are the new
demonstration's, as without ``--library``.  Its segments are the recognised parts in time order:

- a **known** part is the library's sub-template *copied with provenance*: its stored path,
  re-timed to the span where it was seen (its own timing profile stretched to the span's
  samples) and carried there by the similarity (translation, rotation, scale) that the
  recognition fitted, replaces the demonstration's samples of that span.  So a program that
  runs the written template runs the library's sub-template, warped by OSILA like any other;
  the tag is the library's tag (``reach``, ``draw``; the template's name for an unsegmented
  one; ``_2``, ``_3`` added if repeated) and the contact flag is the library's.  The template's
  description names, per known segment, the library template, its file and the distance.
- a **new** part keeps the demonstrated samples and becomes one segment, tagged ``new1``,
  ``new2``, ... or by ``--tags`` (one per new part, in order); ``--contact`` flags them.

A template file has a fixed schema (:mod:`hila_lang.osila.template`), so provenance lives in the
description and in the report, not in a new field: any hila reads the file unchanged.

**The report** (``--report FILE.json``)::

    {"segments": [{"start": S, "end": E, "template": NAME or null, "tag": TAG or null,
                   "distance": D or null}, ...]}

S and E are samples of the input path (E exclusive), in time order, covering it; a new part has
template, tag and distance null.
"""

from __future__ import annotations

import json
import os
import re

import numpy as np

from ..core.errors import InputError
from ..core.fileio import atomic_write_text
from ..osila.template import Segment, Template
from .library import REFERENCE_POINTS
from .search import Part
from .shape import arc_length, arc_resample, similarity_map, smooth


def report(parts: list[Part]) -> dict:
    """The report document (see the module docstring)."""
    return {"segments": [p.as_report() for p in parts]}


def write_report(path: str | os.PathLike, parts: list[Part]):
    """Write :func:`report` as JSON, atomically."""
    return atomic_write_text(path, json.dumps(report(parts), indent=1) + "\n")


def placed(library_part: Template, seen: np.ndarray) -> np.ndarray:
    """``library_part``'s path re-timed to len(seen) samples and moved by the similarity that fits it to ``seen``.

    The similarity is fitted between both at equal arc-length steps (as recognition compared
    them); the re-timing keeps the library part's own speed profile (its times, or its index).
    """
    own = library_part.path
    t = np.arange(len(own), dtype=float) if library_part.times is None else library_part.times
    u = np.linspace(t[0], t[-1], len(seen))
    timed = np.column_stack([np.interp(u, t, own[:, d]) for d in range(own.shape[1])])
    a = arc_resample(smooth(own), REFERENCE_POINTS)
    b = arc_resample(smooth(seen), REFERENCE_POINTS, arc_length(smooth(seen)))
    return similarity_map(a, b)(timed)


def recognised_template(template: Template, parts: list[Part], library: dict[str, Template],
                        new_tags: list[str] | None = None, contact=()) -> Template:
    """``template`` (the new demonstration) cut into ``parts``, known parts copied from ``library``.

    ``library`` maps template name -> Template.  ``new_tags``: one per new part (default
    ``new1``, ``new2``, ...); ``contact``: tags of new parts that touch the surface.
    """
    new = [p for p in parts if not p.known]
    if new_tags and len(new_tags) != len(new):
        raise InputError(f"--tags names the new parts: expected {len(new)} tag(s) for the {len(new)} new part(s), "
                         f"got {len(new_tags)}: {', '.join(new_tags)}")
    contact = set(contact)
    names = iter(new_tags or [f"new{i + 1}" for i in range(len(new))])
    path = template.path.copy()
    segments, used, lines = [], {}, []
    for p in parts:
        if p.known:
            source = library[p.template]
            sub = source.sub(p.tag) if p.tag is not None else source
            path[p.start:p.end] = placed(sub, template.path[p.start:p.end])
            base = p.tag or p.template
            used[base] = used.get(base, 0) + 1
            tag = base if used[base] == 1 else f"{base}_{used[base]}"
            flag = source.segment(p.tag).contact if p.tag is not None else False
            lines.append(f"{tag} [{p.start}, {p.end}) = {sub.name} from {p.source or 'the library'} "
                         f"(distance {p.distance:.3f})")  # read back by library_parts
        else:
            tag = next(names)
            flag = tag in contact
        segments.append(Segment(tag, p.start, p.end, bool(flag)))
    fresh = [s.tag for s, p in zip(segments, parts) if not p.known]
    unknown = sorted(contact - set(fresh))
    if unknown:
        raise InputError(f"--contact {unknown[0]!r} is not the tag of a new part (new parts: {', '.join(fresh) or 'none'})")
    known = ("Known parts, copied from the library (similarity-moved to where they were seen): "
             + "; ".join(lines) + ".") if lines else "No library part was recognised."
    return Template(template.name, path, {k: v.copy() for k, v in template.icps.items()},
                    times=None if template.times is None else template.times.copy(), segments=segments,
                    description=f"{template.description} {known}".strip(), units=template.units)


_KNOWN = re.compile(r"(?P<tag>[A-Za-z_]\w*) \[(?P<start>\d+), (?P<stop>\d+)\) = (?P<part>\S+) from (?P<file>.+?) "
                    r"\(distance (?P<distance>[0-9.]+)\)")
_HEAD = "Known parts, copied from the library"


def library_parts(template: Template) -> list[str]:
    """The library parts a template written by :func:`recognised_template` runs, one phrase each.

    Read back from the description (the format :func:`recognised_template` writes).  For a
    sub-template (``NAME.TAG``, whose description starts with its segment) only its own part;
    ``[]`` for a template that was not recognised against a library.
    """
    text = template.description
    if _HEAD not in text:
        return []
    found = [m.groupdict() for m in _KNOWN.finditer(text[text.index(_HEAD):])]
    own = re.match(r"segment '([^']+)' \[", text)
    if own:  # a sub-template: its segment only
        found = [f for f in found if f["tag"] == own.group(1)]
    return [f"{f['part']} (from {f['file']}, recognised at distance {f['distance']}) as {f['tag']}" for f in found]
