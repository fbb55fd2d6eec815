"""``hila learn``: a demonstration CSV plus its ICPs -> a segmented template YAML."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "learn a template from one demonstration (CSV path + ICPs), segmented and tagged"
DESCRIPTION = """\
Learn a template from ONE demonstration and store it as human-readable YAML.

DEMO.csv: a header line, then one row per waypoint.  Header 't,x,y', 't,x,y,z', 'x,y' or 'x,y,z'
(t in seconds, strictly increasing; x, y, z in metres).  Blank lines and lines starting with '#'
are skipped.
ICPS: the demonstration scene's invariant control points, a YAML mapping 'name: [x, y, z]'
(or a task YAML with an 'icps:' mapping).
The path is split into k contiguous segments (k-means on position + time, or equal sizes), tagged
in time order with --tags; --contact names the tags that touch the surface (drawing).
Example: hila learn demo.csv --icps scene.yaml -k 3 --tags reach,draw,retract --contact draw \\
-o primitives/circle.yaml"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("demo", metavar="DEMO.csv", help="demonstrated path (header t,x,y[,z] or x,y[,z])")
    parser.add_argument("--icps", required=True, metavar="ICPS.yaml", help="scene ICPs: name: [x, y, z]")
    parser.add_argument("-k", type=int, default=None, help="number of segments (default: number of --tags, or 1)")
    parser.add_argument("--tags", default=None, help="comma-separated segment tags in time order")
    parser.add_argument("--contact", default="", help="comma-separated tags that touch the surface")
    parser.add_argument("--method", choices=("kmeans", "equal"), default="kmeans", help="segmentation method")
    parser.add_argument("--seed", type=int, default=0, help="k-means seed (default 0)")
    parser.add_argument("--name", default=None, help="template name (default: the output file's stem)")
    parser.add_argument("--description", default=None, help="provenance text stored in the template")
    parser.add_argument("-o", "--output", required=True, metavar="OUT.yaml", help="template file to write")


def _split(text: str | None) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()] if text else []


def read_demo_csv(path: str | Path):
    """Read a demonstration CSV: returns (path (T, D), times (T,) or None).

    Raises InputError naming the file and line for a bad header, a ragged row, a non-number,
    non-increasing times or no data rows.
    """
    import numpy as np

    from ..errors import InputError
    from ..fileio import read_text

    text = read_text(path, "demonstration CSV")
    rows = []
    for no, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if line and not line.startswith("#"):
            rows.append((no, raw, [c.strip() for c in line.split(",")]))
    if not rows:
        raise InputError("demonstration CSV is empty; expected a header 't,x,y[,z]' and rows", file=str(path))
    no, raw, header = rows[0]
    header = [h.lower() for h in header]
    if header not in (["t", "x", "y"], ["t", "x", "y", "z"], ["x", "y"], ["x", "y", "z"]):
        raise InputError(
            f"expected the header 't,x,y', 't,x,y,z', 'x,y' or 'x,y,z', got {','.join(header)!r}",
            file=str(path), line=no, source_line=raw,
        )
    data = []
    for no, raw, cells in rows[1:]:
        if len(cells) != len(header):
            raise InputError(
                f"expected {len(header)} columns ({','.join(header)}), got {len(cells)}",
                file=str(path), line=no, source_line=raw,
            )
        values = []
        for name, cell in zip(header, cells):
            try:
                v = float(cell)
            except ValueError:
                v = None
            if v is None or not np.isfinite(v):
                raise InputError(
                    f"expected a finite number in column {name!r}, got {cell!r}",
                    file=str(path), line=no, source_line=raw,
                )
            values.append(v)
        if data and header[0] == "t" and values[0] <= data[-1][1][0]:
            raise InputError(
                f"expected increasing times in column 't', got {values[0]!r} after {data[-1][1][0]!r}",
                file=str(path), line=no, source_line=raw,
            )
        data.append((no, values))
    if not data:
        raise InputError("demonstration CSV has a header but no data rows", file=str(path))
    arr = np.array([v for _, v in data])
    if header[0] == "t":
        return arr[:, 1:], arr[:, 0]
    return arr, None


def load_icps(path: str | Path, dim: int) -> dict:
    """Read ICPs from YAML: a mapping name -> [x, y(, z)], or a task file's 'icps' mapping."""
    from ..errors import InputError
    from ..fileio import load_yaml

    doc = load_yaml(path, "ICP file", unique_keys=True)
    if isinstance(doc, dict) and isinstance(doc.get("icps"), dict):
        doc = doc["icps"]
    if not isinstance(doc, dict) or not doc:
        got = "an empty file" if not doc else type(doc).__name__
        raise InputError(f"expected a mapping of ICPs 'name: [x, y{', z' if dim == 3 else ''}]', got {got}", file=str(path))
    for name, point in doc.items():
        if not (isinstance(point, list) and len(point) == dim and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in point)):
            raise InputError(f"expected ICP {name!r} as {dim} numbers (the demonstration's D), got {point!r}", file=str(path))
    return {str(k): v for k, v in doc.items()}


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError
    from ..segmentation import segment_template
    from ..template import Template, save_template

    demo, times = read_demo_csv(args.demo)
    icps = load_icps(args.icps, demo.shape[1])
    tags = _split(args.tags)
    contact = _split(args.contact)
    k = args.k if args.k is not None else max(len(tags), 1)
    if k < 1:
        raise InputError(f"expected -k >= 1, got {k}")
    if not tags and k > 1:
        tags = [f"s{i + 1}" for i in range(k)]
    out = Path(args.output)
    name = args.name or out.stem
    description = args.description or f"learned from {args.demo} ({len(demo)} points) with ICPs from {args.icps}"
    try:
        template = Template(name, demo, icps, times=times, description=description)
    except InputError as exc:
        exc.file = exc.file or str(args.demo)
        raise
    if tags:
        template = segment_template(template, k, tags, method=args.method, seed=args.seed, contact=contact)
    elif contact:
        raise InputError("--contact needs segments: give --tags (and -k)")
    save_template(template, out)
    print(f"learned template {name!r}: {len(demo)} points, D = {demo.shape[1]}, {len(icps)} ICPs -> {out}")
    for seg in template.segments:
        flag = " (contact)" if seg.contact else ""
        print(f"  {seg.tag:<12} [{seg.start}, {seg.stop}){flag}")
    return 0
