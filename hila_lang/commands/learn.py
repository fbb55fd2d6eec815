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


def run(args: argparse.Namespace) -> int:
    from ..demofile import load_icps, read_demo_csv
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
