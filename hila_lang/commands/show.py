"""``hila show NAME``: what a template or a world offers a program, without reading YAML.

For a template (``hila show circle``, or a path ``hila show my/reach.yaml``): its tags with their
spans in samples and seconds and whether the pen touches, its ICPs with their positions, and a
small picture of the path seen from above with its cuts; ``--plot FILE.png`` draws it
(:func:`hila_lang.session.plot.plot_path`).  For a world (``hila show world tictactoe``): its
points, questions, events and settings with their docs, read from the one table the world
answers through and ``hila check`` checks by (:mod:`hila_lang.plugins.names`).
"""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

from ..core.errors import did_you_mean, InputError
from ..core.fileio import check_regular
from ..core.resources import template_search_path
from ..plugins import registry
from ..plugins.settings import show_value

HELP = "show a template (tags, ICPs, a picture of its path) or a world (points, questions, events, settings)"
DESCRIPTION = """\
Show what a program can use.

  hila show TEMPLATE [--plot FILE.png]   a template by name (import NAME finds it the same way:
                                         HILA_PATH, ./primitives, the shipped templates) or a
                                         .yaml path: its tags (sub-templates) with their spans in
                                         samples and seconds and the pen's contact, its ICPs and
                                         where they are, a picture of the path from above with
                                         its cuts (--plot: top and side views as a PNG)
  hila show world [NAME]                 a world's points, questions (ask), events (wait) and
                                         settings (--set) with their docs; without NAME, the
                                         worlds there are"""

#: the text picture's size, characters (two characters a cell across, so it looks square)
PICTURE_COLUMNS, PICTURE_ROWS = 56, 16
WRAP = 96


def add_arguments(parser) -> None:
    parser.add_argument("name", metavar="NAME", help="a template name or .yaml file, or 'world'")
    parser.add_argument("world", nargs="?", default=None, metavar="WORLD",
                        help="with 'world': the world to show (default: list the worlds)")
    parser.add_argument("--plot", default=None, metavar="FILE.png",
                        help="a template: also draw its path, cuts and ICPs (top and side views) into FILE.png")


def run(args) -> int:
    if args.name == "world":
        if args.plot:
            raise InputError("--plot draws a template; a world has no path to draw")
        print(world_text(args.world) if args.world else worlds_text())
        return 0
    if args.world is not None:
        raise InputError(f"expected one template name, got {args.name!r} and {args.world!r}",
                         hint="hila show TEMPLATE, or hila show world NAME")
    path, template = find_template(args.name)
    print(template_text(template, path))
    if args.plot:
        out = plot_template(template, args.plot)
        print(f"plot written to {out}")
    return 0


# --------------------------------------------------------------------------- templates


def find_template(name: str):
    """``(path, Template)`` for a name as ``import NAME`` finds it, or a ``.yaml`` path."""
    # lazy: loads numpy, which importing this module does not
    from ..osila.template import load_template

    given = Path(name)
    if given.suffix in (".yaml", ".yml") or os.path.lexists(given):  # a file, folder, FIFO, link: it says what it is
        check_regular(given, "template file")
        return given, load_template(given)
    folders = template_search_path(None)
    found = next((d / f"{name}.yaml" for d in folders if (d / f"{name}.yaml").is_file()), None)
    if found is None:
        known = sorted({f.stem for d in folders if d.is_dir() for f in d.glob("*.yaml")})
        raise InputError(f"template {name!r} not found (looked in {', '.join(str(d) for d in folders)})",
                         hint=did_you_mean(name, known) or (f"templates found: {', '.join(known)}" if known
                                                            else "add the folder that holds it to HILA_PATH"))
    return found, load_template(found)


def _relative(path) -> str:
    try:
        return str(Path(path).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _point(p) -> str:
    return "(" + ", ".join(f"{float(v):+.3f}" for v in p) + ")"


def template_text(template, path=None) -> str:
    """The text ``hila show TEMPLATE`` prints."""
    t = template
    n = len(t.path)
    duration = f" over {t.times[-1] - t.times[0]:.2f} s" if t.times is not None else ""
    units = {"m": "metres"}.get(t.units, t.units)
    where = f" ({_relative(path)})" if path is not None else ""
    lines = [f"template {t.name}{where}: {t.dim}-D, {n} points{duration}, {units}"]
    if t.description:  # whole: how it was made, cut, and moved by hand is what a reader needs
        lines += textwrap.wrap(t.description, WRAP, initial_indent="  ", subsequent_indent="  ")
    lines.append("")
    if t.segments:
        lines.append(f"tags (sub-templates: run {t.name}.TAG(ICP = point, ...)):")
        width = max(len(s.tag) for s in t.segments)
        for k, s in enumerate(t.segments, 1):
            span = f"points {s.start}..{s.stop - 1}"
            seconds = f"  {t.times[s.start]:.2f}-{t.times[s.stop - 1]:.2f} s" if t.times is not None else ""
            lines.append(f"  {k} {s.tag:<{width}}  {span:<16} ({s.stop - s.start} samples){seconds}  "
                         f"pen {'down' if s.contact else 'up'}")
    else:
        lines.append(f"tags: none (not segmented: run {t.name}(ICP = point, ...) runs it whole)")
    lines.append("")
    lines.append(f"ICPs ({units}; bind them by name, e.g. run {t.name}{'.' + t.tags()[0] if t.segments else ''}"
                 f"({next(iter(t.icps))} = ...)):")
    width = max(len(k) for k in t.icps)
    for k, (name, p) in enumerate(t.icps.items()):
        lines.append(f"  {_letter(k)} {name:<{width}}  {_point(p)}")
    if t.segments:
        lines.append("  every sub-template adds 'start' and 'end': its first and last points")
    # lazy: loads numpy, which importing this module does not
    from ..session.plot import PAPER_VIEW

    lines.append("")
    lines.append(f"path from above, {PAPER_VIEW}: digits = the tag's points, | = a cut, letters = ICPs, "
                 "* = start")
    lines += ["  " + row for row in picture(t)]
    drawn = small_drawing(t)
    if drawn is not None:  # the mark is small beside the whole: shown again, fitted
        lines.append("")
        lines.append("the drawing (pen down), zoomed to fit:")
        lines += ["  " + row for row in picture(t, only=drawn)]
    return "\n".join(lines)


def small_drawing(template):
    """Indices of the template's pen-down (contact) samples when they span less than a third of
    its whole path (a mark beside a far hand's start: worth a second, fitted picture), else None."""
    # lazy: loads numpy, which importing this module does not
    import numpy as np

    idx = [np.arange(s.start, s.stop) for s in template.segments if s.contact]
    if not idx:
        return None
    drawn = np.concatenate(idx)
    path = np.asarray(template.path, float)
    return drawn if len(drawn) >= 2 and np.ptp(path[drawn], axis=0).max() < np.ptp(path, axis=0).max() / 3 else None


def _letter(k: int) -> str:
    return chr(ord("A") + k) if k < 26 else "?"


def picture(template, columns: int = PICTURE_COLUMNS, rows: int = PICTURE_ROWS, only=None) -> list[str]:
    """The path from above, the paper as the robot sees it (:func:`hila_lang.session.plot.paper_view`),
    as ``rows`` strings of ``columns`` characters, framed: each point is the
    number of the tag it belongs to, the first point of every tag after the first a ``|`` (a cut),
    each ICP its letter, the start ``*``; later marks draw over earlier ones in that order.
    ``only`` (indices of the path): fitted to those points (what falls outside is left out)."""
    # lazy: loads numpy, which importing this module does not
    import numpy as np

    from ..session.plot import paper_view

    xy = paper_view(np.asarray(template.path, dtype=float))
    icps = [paper_view(np.asarray(p, dtype=float), template.dim) for p in template.icps.values()]
    everything = np.vstack([xy] + icps) if only is None else xy[only]
    lo, hi = everything.min(0), everything.max(0)
    span = max(float((hi - lo).max()), 1e-9)
    mid = (lo + hi) / 2
    # equal metres per character across and down: a character is about twice as tall as wide
    scale = min((columns - 1) / span, 2 * (rows - 1) / span)

    def cell(p):
        c = int(round((p[0] - mid[0]) * scale + (columns - 1) / 2))
        r = int(round((rows - 1) / 2 - (p[1] - mid[1]) * scale / 2))
        if only is not None and not (0 <= r < rows and 0 <= c < columns):
            return None
        return min(max(r, 0), rows - 1), min(max(c, 0), columns - 1)

    grid = [[" "] * columns for _ in range(rows)]

    def put(p, ch):
        where = cell(p)
        if where is not None:
            grid[where[0]][where[1]] = ch

    segments = template.segments or []
    owner = np.zeros(len(xy), dtype=int)
    for k, s in enumerate(segments, 1):
        owner[s.start:s.stop] = k
    for i, p in enumerate(xy):
        put(p, str(owner[i] % 10) if segments else ".")
    for s in segments[1:]:
        put(xy[s.start], "|")
    for k, p in enumerate(icps):
        put(p, _letter(k))
    put(xy[0], "*")
    border = "+" + "-" * columns + "+"
    return [border] + ["|" + "".join(row) + "|" for row in grid] + [border]


def plot_template(template, file):
    """The template's path, cuts and ICPs as a PNG (top and side views)."""
    # lazy: loads numpy, which importing this module does not
    from ..session.plot import plot_path

    marks = [(s.start, s.tag) for s in template.segments]
    return plot_path(template.path, file, icps=template.icps, title=f"template {template.name}", marks=marks,
                     legend="blue the path, orange x where each tag starts", zoom=small_drawing(template))


# --------------------------------------------------------------------------- worlds


def worlds_text() -> str:
    lines = ["worlds (world NAME in a program; 'hila show world NAME' for one):"]
    infos = registry.declarations("world")
    width = max(len(i.name) for i in infos)
    for info in infos:
        lines.append(f"  {info.name:<{width}}  {info.doc}")
    return "\n".join(lines)


def _rows(entries, width: int) -> list[str]:
    out = []
    for name, doc in entries:
        head = f"  {name:<{width}}  "
        body = textwrap.wrap(doc, max(WRAP - len(head), 30)) or [""]
        out.append(head + body[0])
        out += [" " * len(head) + more for more in body[1:]]
    return out


def world_text(name: str) -> str:
    """The text ``hila show world NAME`` prints: from the world's declared table."""
    info = registry.world(name)
    lines = [f"world {info.name}: {info.doc}",
             f"default back end: {info.default_backend}; drawing surface (paper, for 2-D templates): "
             f"{'yes' if info.drawing_surface else 'no'}"]
    sections = [
        ("points (write them out; a group binds a template's ICPs of the same names: run T(g.*))",
         [(e.signature, e.doc) for e in info.points.entries]),
        ("questions (ask NAME)", [(e.signature, e.doc) for e in info.questions.entries]),
        ("events (wait NAME)", [(e.signature, e.doc) for e in info.events.entries]),
        ("settings (--set NAME=VALUE)",
         [(f"{s.name}={s.metavar}", s.doc + ("" if s.default is None else f" (default: {show_value(s.default)})")
           + (f"; also {s.flag}" if s.flag else "")) for s in info.settings]),
    ]
    names = [n for _, entries in sections for n, _ in entries]
    width = min(max((len(n) for n in names), default=0), 30)
    for title, entries in sections:
        lines.append("")
        lines.append(title + ":")
        if entries:
            lines += _rows(entries, width)
        elif info.dynamic_names and not title.startswith("settings"):
            lines.append("  whatever the running world names" + (
                " (its script: --set script=FILE.yaml)" if info.declare else ""))
            if title.startswith("points"):
                lines.append("  and a program names its own: point home = (0.18, -0.25, 0.75)")
        else:
            lines.append("  none")
    return "\n".join(lines)
