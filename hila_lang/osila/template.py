"""Templates: one demonstrated path with named ICPs and tagged sub-templates, stored as YAML.

A :class:`Template` is what OSILA imitates: a path (T, D), D = 2 or 3, the invariant control
points (ICPs) of the demonstration scene by name, optional time stamps, and an ordered list of
tagged :class:`Segment` s (index ranges) that cut the path into sub-templates.

File format (``primitives/NAME.yaml``), meant to be read and edited by hand::

    hila_template: 1              # schema version
    name: circle_cell
    description: "one demonstration: reach a cell, draw a circle, retract"
    units: m
    icps:                         # ordered; names unique
      cell.tl: [0.25, -0.12, 0.57]
      hand: [0.20, -0.10, 0.70]
    segments:                     # ordered, contiguous, covering 0..T; stop is exclusive
      - {tag: reach, start: 0, stop: 40, contact: false}
      - {tag: draw, start: 40, stop: 160, contact: true}
      - {tag: retract, start: 160, stop: 200, contact: false}
    times: [0.0, 0.05, ...]       # optional, seconds, strictly increasing, one per path row
    path:
      - [0.20, -0.10, 0.70]
      - ...

Move a segment boundary or rename a tag and the next run uses it.  Floats are written with
``repr`` precision, so a save/load round trip is lossless.  Unknown fields, duplicate keys (e.g.
two ICPs of the same name), ragged rows, overlapping or gapped segments raise
:class:`~hila_lang.core.errors.InputError` naming the file and the field.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import InputError
from ..core.fileio import atomic_write_text, load_yaml, yaml_text
from ..core.validation import check_path

SCHEMA_VERSION = 1
_FIELDS = ("hila_template", "name", "description", "units", "icps", "segments", "times", "path")
_REQUIRED = ("hila_template", "name", "icps", "path")
_SEGMENT_FIELDS = ("tag", "start", "stop", "contact")
#: ICP names a sub-template adds (they override parent ICPs of the same name)
START, END = "start", "end"
#: the largest coordinate a template, an ICP or a demonstration may hold, in its units
#: (metres or pixels): 1000 km, or a million pixels.  Larger finite numbers (1e308) overflow
#: OSILA's thin plate spline (squares of distances) into a singular system (issue 20).
MAX_COORDINATE = 1e6


def check_coordinates(values, what: str, file: str | None = None) -> None:
    """Refuse a coordinate larger than :data:`MAX_COORDINATE` in ``values`` (finite already):
    an :class:`InputError` naming ``what`` and the value."""
    arr = np.asarray(values, dtype=float)
    if arr.size and np.abs(arr).max() > MAX_COORDINATE:
        worst = float(arr.flat[int(np.argmax(np.abs(arr)))])
        raise InputError(f"expected coordinates within +-{MAX_COORDINATE:g} in {what}, got {worst:g}", file=file,
                         hint="a template's units are metres or pixels")


@dataclass
class Segment:
    """A tagged sub-template: the index range ``[start, stop)`` of the parent path.

    Attributes
    ----------
    tag : str
        Name of the sub-template (``"reach"``, ``"draw"``, ...), unique in its template.
    start, stop : int
        First index (inclusive) and end index (exclusive) in the parent path.
    contact : bool
        The pen/hand touches the surface during this segment (drawing).
    """

    tag: str
    start: int
    stop: int
    contact: bool = False


@dataclass
class Template:
    """One demonstration: path, named ICPs, optional times and tagged segments.

    Attributes
    ----------
    name : str
        Template name (the file stem by convention).
    path : ndarray, shape (T, D)
        Demonstrated waypoints, D in {2, 3}, in ``units`` (metres by default).
    icps : dict[str, ndarray]
        Ordered name -> point of shape (D,): the demonstration scene's invariant control points.
    times : ndarray, shape (T,), optional
        Time stamps in seconds, strictly increasing.
    segments : list[Segment]
        Ordered, contiguous, covering ``[0, T)``; empty means "not segmented".
    description : str
        Provenance: how the demonstration was made.
    units : str
        Length unit of ``path`` and ``icps``.

    Construction validates and converts (lists become float arrays); a problem raises
    :class:`~hila_lang.core.errors.InputError` naming the field.
    """

    name: str
    path: np.ndarray
    icps: dict[str, np.ndarray]
    times: np.ndarray | None = None
    segments: list[Segment] = field(default_factory=list)
    description: str = ""
    units: str = "m"

    def __post_init__(self) -> None:
        _validate(self)

    @property
    def dim(self) -> int:
        """D, the path's dimension (2 or 3)."""
        return int(self.path.shape[1])

    def tags(self) -> list[str]:
        """Segment tags in order."""
        return [s.tag for s in self.segments]

    def segment(self, tag: str) -> Segment:
        """The :class:`Segment` tagged ``tag``; ``KeyError`` listing the known tags otherwise."""
        for seg in self.segments:
            if seg.tag == tag:
                return seg
        raise KeyError(f"template {self.name!r} has no segment {tag!r}; known: {self.tags()}")

    def sub(self, tag: str) -> Template:
        """The sub-template tagged ``tag``.

        Its path is ``path[start:stop]`` (times likewise), its ICPs are the parent's ICPs plus
        ``"start"`` = its first point and ``"end"`` = its last point (these two override parent
        ICPs of the same name), its name is ``"<parent>.<tag>"`` and it has one segment with the
        same tag and contact flag.
        """
        seg = self.segment(tag)
        path = self.path[seg.start : seg.stop].copy()
        icps = {k: v.copy() for k, v in self.icps.items() if k not in (START, END)}
        icps[START] = path[0].copy()
        icps[END] = path[-1].copy()
        times = None if self.times is None else self.times[seg.start : seg.stop].copy()
        return Template(
            name=f"{self.name}.{tag}",
            path=path,
            icps=icps,
            times=times,
            segments=[Segment(tag, 0, len(path), seg.contact)],
            description=f"segment {tag!r} [{seg.start}, {seg.stop}) of {self.name}. {self.description}".strip(),
            units=self.units,
        )


def _validate(t: Template) -> None:
    """Convert and check every field of ``t`` in place (InputError names the field)."""
    if not isinstance(t.name, str) or not t.name:
        raise InputError(f"expected field 'name' as a non-empty string, got {t.name!r}")
    if not isinstance(t.description, str):
        raise InputError(f"expected field 'description' as a string, got {t.description!r}")
    if not isinstance(t.units, str) or not t.units:
        raise InputError(f"expected field 'units' as a non-empty string, got {t.units!r}")
    t.path = check_path(t.path, "field 'path'")
    check_coordinates(t.path, "field 'path'")
    T, D = t.path.shape
    if not isinstance(t.icps, dict):
        raise InputError(f"expected field 'icps' as a mapping name -> point, got {type(t.icps).__name__}")
    icps: dict[str, np.ndarray] = {}
    for key, value in t.icps.items():
        if not isinstance(key, str) or not key:
            raise InputError(f"expected ICP names as non-empty strings in field 'icps', got {key!r}")
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"expected field 'icps.{key}' as {D} numbers, got {value!r}") from None
        if arr.shape != (D,):
            raise InputError(f"expected field 'icps.{key}' as {D} numbers (the path's D), got shape {arr.shape}")
        if not np.isfinite(arr).all():
            raise InputError(f"expected finite numbers in field 'icps.{key}', got {arr.tolist()}")
        check_coordinates(arr, f"field 'icps.{key}'")
        icps[key] = arr
    t.icps = icps
    if t.times is not None:
        try:
            times = np.asarray(t.times, dtype=float)
        except (TypeError, ValueError):
            raise InputError("expected field 'times' as a list of numbers") from None
        if times.shape != (T,):
            raise InputError(f"expected field 'times' with one entry per path row ({T}), got shape {times.shape}")
        if not np.isfinite(times).all():
            raise InputError("expected finite numbers in field 'times'")
        if T > 1 and not (np.diff(times) > 0).all():
            i = int(np.argmin(np.diff(times) > 0))
            raise InputError(
                f"expected field 'times' strictly increasing, got {times[i]} then {times[i + 1]} at index {i + 1}"
            )
        t.times = times
    if not isinstance(t.segments, list):
        raise InputError(f"expected field 'segments' as a list, got {type(t.segments).__name__}")
    check_segments(t.segments, T)


def check_segments(segments: list[Segment], length: int, where: str = "segments") -> None:
    """Check that ``segments`` are ordered, contiguous, non-empty, uniquely tagged and cover ``[0, length)``.

    An empty list is allowed (an unsegmented template).  Errors name the field as
    ``'segments[i].attr'``.
    """
    expected = 0
    seen: set[str] = set()
    for i, seg in enumerate(segments):
        at = f"{where}[{i}]"
        if not isinstance(seg, Segment):
            raise InputError(f"expected field '{at}' as a Segment, got {type(seg).__name__}")
        if not isinstance(seg.tag, str) or not seg.tag:
            raise InputError(f"expected field '{at}.tag' as a non-empty string, got {seg.tag!r}")
        if seg.tag in seen:
            raise InputError(f"duplicate tag {seg.tag!r} in field '{at}.tag'; tags must be unique")
        seen.add(seg.tag)
        for attr in ("start", "stop"):
            v = getattr(seg, attr)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise InputError(f"expected field '{at}.{attr}' as an integer, got {v!r}")
        if not isinstance(seg.contact, (bool, np.bool_)):
            raise InputError(f"expected field '{at}.contact' as true or false, got {seg.contact!r}")
        if seg.start != expected:
            kind = "overlaps the previous one" if seg.start < expected else "leaves a gap"
            raise InputError(f"segment {seg.tag!r} (field '{at}') {kind}: expected start = {expected}, got {seg.start}")
        if seg.stop <= seg.start:
            raise InputError(f"segment {seg.tag!r} (field '{at}') is empty: start {seg.start}, stop {seg.stop}")
        if seg.stop > length:
            raise InputError(
                f"segment {seg.tag!r} (field '{at}') is out of range: stop {seg.stop} > path length {length}"
            )
        expected = int(seg.stop)
    if segments and expected != length:
        raise InputError(f"field '{where}' does not cover the path: last stop is {expected}, path length is {length}")


# --------------------------------------------------------------------------- YAML


def template_to_dict(template: Template) -> dict[str, Any]:
    """The YAML document for ``template`` (plain Python types, floats exact)."""
    doc: dict[str, Any] = {
        "hila_template": SCHEMA_VERSION,
        "name": template.name,
        "description": template.description,
        "units": template.units,
        "icps": {k: [float(x) for x in v] for k, v in template.icps.items()},
        "segments": [
            {"tag": s.tag, "start": int(s.start), "stop": int(s.stop), "contact": bool(s.contact)}
            for s in template.segments
        ],
    }
    if template.times is not None:
        doc["times"] = [float(x) for x in template.times]
    doc["path"] = [[float(x) for x in row] for row in template.path]
    return doc


def template_from_dict(doc: Any, source: str = "<template>") -> Template:
    """Build a :class:`Template` from a parsed YAML document; errors name ``source`` and the field."""
    if not isinstance(doc, dict):
        got = "an empty file" if doc is None else type(doc).__name__
        raise InputError(f"expected a hila template (a mapping with 'hila_template: 1'), got {got}", file=source)
    unknown = [k for k in doc if k not in _FIELDS]
    if unknown:
        raise InputError(
            f"unknown field {unknown[0]!r}; expected fields: {', '.join(_FIELDS)}", file=source
        )
    missing = [k for k in _REQUIRED if k not in doc]
    if missing:
        raise InputError(f"missing field {missing[0]!r}", file=source)
    if doc["hila_template"] != SCHEMA_VERSION:
        raise InputError(
            f"unsupported template version in field 'hila_template': expected {SCHEMA_VERSION}, "
            f"got {doc['hila_template']!r}",
            file=source,
        )
    segments = []
    raw_segments = doc.get("segments") or []
    if not isinstance(raw_segments, list):
        raise InputError(f"expected field 'segments' as a list, got {type(raw_segments).__name__}", file=source)
    for i, raw in enumerate(raw_segments):
        if not isinstance(raw, dict):
            raise InputError(f"expected field 'segments[{i}]' as a mapping {{tag, start, stop, contact}}", file=source)
        bad = [k for k in raw if k not in _SEGMENT_FIELDS]
        if bad:
            raise InputError(
                f"unknown field {bad[0]!r} in 'segments[{i}]'; expected: {', '.join(_SEGMENT_FIELDS)}", file=source
            )
        lost = [k for k in ("tag", "start", "stop") if k not in raw]
        if lost:
            raise InputError(f"missing field {lost[0]!r} in 'segments[{i}]'", file=source)
        segments.append(Segment(raw["tag"], raw["start"], raw["stop"], raw.get("contact", False)))
    path = doc["path"]
    if isinstance(path, list):
        widths = {len(r) if isinstance(r, list) else -1 for r in path}
        if len(widths) > 1 or -1 in widths:
            row = next(i for i, r in enumerate(path) if not isinstance(r, list) or len(r) != len(path[0] or []))
            raise InputError(
                f"expected field 'path' as rows of equal length, row {row} is {path[row]!r}", file=source
            )
    icps = doc["icps"]
    if icps is None:
        icps = {}
    try:
        return Template(
            name=doc["name"],
            path=path,
            icps=icps,
            times=doc.get("times"),
            segments=segments,
            description=doc.get("description") or "",
            units=doc.get("units") or "m",
        )
    except InputError as exc:
        exc.file = source
        raise


def load_template(path: str | os.PathLike) -> Template:
    """Load and validate a template YAML file.

    Raises
    ------
    InputError
        Naming the file (and line/column for YAML errors) and the offending field: a missing or
        non-YAML file, duplicate keys, unknown fields, wrong shapes, bad segments.
    """
    doc = load_yaml(path, "template", unique_keys=True)
    return template_from_dict(doc, str(path))


def template_text(template: Template) -> str:
    """``template`` as the human-readable YAML :func:`load_template` reads, with a header comment."""
    _validate(template)
    header = (
        f"hila template {template.name!r} (schema {SCHEMA_VERSION}); edit by hand freely.\n"
        "segments: ordered, contiguous, stop exclusive; icps: name -> point; path: one row per waypoint."
    )
    return yaml_text(template_to_dict(template), header=header)


def save_template(template: Template, path: str | os.PathLike) -> Path:
    """Write ``template`` as human-readable YAML (:func:`template_text`), atomically; returns the path written."""
    return atomic_write_text(path, template_text(template))
