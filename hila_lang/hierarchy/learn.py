"""Learning: ONE demonstration -> a template cut into tagged sub-templates (HILA's first half).

:func:`learn` takes the demonstration as numbers (a path, its time stamps, its scene ICPs) and
cuts it into ``k`` contiguous segments tagged in time order
(:func:`hila_lang.osila.segmentation.segment_template`; without tags it stays whole).
:func:`learn_files` reads the same from a demonstration CSV and an ICP YAML
(:mod:`hila_lang.osila.demofile`) and says where it came from in the description.  A recorded pen
(the CSV's ``pen`` column) cuts where the pen touches and leaves the paper unless a method is
given; cuts moved by hand (:func:`check_cuts`) replace the method's.

``hila learn`` (the command), the studio's *Save template* and the letters world's handwriting
model all learn through these, so a template made in any of them is byte for byte the file
``hila learn DEMO.csv --icps ICPS.yaml ...`` writes from the same files.  Learning through the
eye cameras (``hila learn --from-sim/--frames``) is :mod:`hila_lang.perception.learn`'s, which
ends in the same segmentation.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ..core.errors import InputError
from ..osila.demofile import load_icps, read_demo
from ..osila.segmentation import DEFAULT_METHOD, describe, segment_template
from ..osila.template import END, START, Segment, Template


def default_tags(tags: Sequence[str], k: int | None) -> tuple[int, list[str]]:
    """(k, tags) as ``hila learn`` reads them: k defaults to the number of tags (or 1); k > 1
    segments without tags are tagged ``s1`` .. ``sk``.  k < 1 is an InputError."""
    tags = list(tags)
    k = k if k is not None else max(len(tags), 1)
    if k < 1:
        raise InputError(f"expected -k >= 1, got {k}")
    if not tags and k > 1:
        tags = [f"s{i + 1}" for i in range(k)]
    return k, tags


def check_cuts(cuts: Sequence[int], k: int, T: int, what: str = "cuts") -> list[int]:
    """``cuts`` as k - 1 increasing sample indices (each the first sample of the next tag) that
    leave every tag 2 samples or more of the T; else an InputError naming ``what``."""
    cuts = [int(c) for c in cuts]
    if len(cuts) != k - 1:
        raise InputError(f"{what}: expected {k - 1} cut(s) for k = {k} segments, got {len(cuts)}")
    bounds = [0, *cuts, T]
    for a, b in zip(bounds, bounds[1:]):
        if b - a < 2:
            raise InputError(f"{what}: expected increasing cuts that leave every tag 2 samples or more of "
                             f"the {T}, got a tag [{a}, {b})")
    return cuts


def learn(name: str, path, icps: dict, *, times=None, tags: Sequence[str] = (), contact: Sequence[str] = (),
          k: int | None = None, method: str | None = None, seed: int = 0, description: str = "",
          source: str | None = None, pen=None, cuts: Sequence[int] | None = None) -> Template:
    """The template of one demonstration.

    Parameters
    ----------
    name : str
        The template's name (a program imports it by this name).
    path : array_like, shape (T, D)
        The demonstrated waypoints, D in {2, 3}, metres (or pixels).
    icps : dict name -> (D,)
        The demonstration scene's invariant control points.
    times : array_like, shape (T,), optional
        Time stamps, seconds, strictly increasing.
    tags, contact : sequences of str
        One tag per segment in time order; the tags whose segments touch the surface.  With the
        pen recorded and no ``contact`` given, the tags whose samples are mostly pen-down touch.
    k, method, seed
        Number of segments (:func:`default_tags`), how they are cut (None: ``"contact"`` -- where
        the pen touches and leaves the paper -- when ``pen`` is recorded, else
        :data:`hila_lang.osila.segmentation.DEFAULT_METHOD`, at the deepest dips in speed) and
        the k-means seed.
    description : str
        Provenance stored in the template.
    source : str, optional
        The file the path and ICPs came from, named by an error in them.
    pen : array_like of bool, shape (T,), optional
        The recorded pen: True where it touches the surface.
    cuts : sequence of int, optional
        The k - 1 cuts by hand (:func:`check_cuts`) instead of a method; the description says so.

    Raises
    ------
    InputError
        A bad path or ICP (named), k < 1, tags that do not match k, contact tags or cuts without
        segments, cuts together with a method.
    """
    k, tags = default_tags(tags, k)
    try:
        template = Template(name, path, icps, times=times, description=description)
    except InputError as exc:
        exc.file = exc.file or source
        raise
    if not tags:
        if contact or cuts is not None:
            raise InputError(f"{'--contact' if contact else '--cuts'} needs segments: give --tags (and -k)")
        return template
    if cuts is None:
        method = method or ("contact" if pen is not None else DEFAULT_METHOD)
        try:
            return segment_template(template, k, tags, method=method, seed=seed, contact=contact, pen=pen)
        except InputError as exc:
            exc.file = exc.file or source
            raise
    if method is not None:
        raise InputError("--cuts and --method both say where to cut: give one")
    bounds = [0, *check_cuts(cuts, k, len(template.path), f"--cuts {','.join(str(c) for c in cuts)}"), len(template.path)]
    if not contact and pen is not None:
        down = np.asarray(pen, bool)
        contact = [tag for tag, a, b in zip(tags, bounds, bounds[1:]) if 2 * np.sum(down[a:b]) > b - a]
    unknown = sorted(set(contact) - set(tags))
    if unknown:
        raise InputError(f"contact tag {unknown[0]!r} is not one of the tags {', '.join(tags)}")
    template.segments = [Segment(tag, bounds[i], bounds[i + 1], tag in contact) for i, tag in enumerate(tags)]
    return template


def learn_files(demo: str | Path, icps: str | Path | None, *, name: str, tags: Sequence[str] = (),
                contact: Sequence[str] = (), k: int | None = None, method: str | None = None, seed: int = 0,
                description: str | None = None, cuts: Sequence[int] | None = None,
                named: tuple[str, str] | None = None) -> Template:
    """:func:`learn` of the demonstration CSV ``demo`` (its ``pen`` column too) with the ICPs of
    the YAML ``icps``.

    ``icps`` None: the demonstration's own ends are its ICPs (``start``, ``end``; recognition needs
    only the path).  The description, unless given, names both files as given (or as ``named``:
    the names they are published under, when they are read from a staging place) and how the path
    was cut, as ``hila learn`` writes it.  A problem with the path names ``demo``."""
    k, tags = default_tags(tags, k)
    recorded = read_demo(demo)
    points = recorded.path
    shown_demo, shown_icps = named or (demo, icps)
    if icps is None:
        scene, given = {START: points[0].copy(), END: points[-1].copy()}, "its own ends as ICPs (start, end; no --icps)"
    else:
        scene, given = load_icps(icps, points.shape[1]), f"ICPs from {shown_icps}"
    if description is None:
        how = ""
        if tags and cuts is not None:
            how = f" Cut by hand at samples {', '.join(str(int(c)) for c in cuts)} (--cuts; k = {k})."
        elif tags:
            how = f" {describe(method or ('contact' if recorded.pen is not None else DEFAULT_METHOD), k)}"
        description = f"learned from {shown_demo} ({len(points)} points) with {given}.{how}"
    return learn(name, points, scene, times=recorded.times, tags=tags, contact=contact, k=k, method=method,
                 seed=seed, description=description, source=str(shown_demo), pen=recorded.pen, cuts=cuts)
