"""``hila imitate``: one template (or one of its sub-templates) imitated in a task scene."""

from __future__ import annotations

import argparse
import difflib
import sys

from ..core.argtypes import output_path
from ..core.errors import InputError
from ..core.fileio import atomic_write_text, ensure_writable, load_yaml
from ..plugins.options import check_osila_options

HELP = "imitate a template in a new scene (OSILA) and write the path as CSV"
DESCRIPTION = """\
Imitate a stored template in a task scene with OSILA and write the generated path as CSV
(header t,x,y[,z] when the template has times, else x,y[,z]; metres, seconds).

TASK.yaml:
  hila_task: 1                     # optional schema version
  icps: {cell.tl: [x, y, z], ...}  # task ICPs by the template's names; 'start'/'end' bind a
                                   # sub-template's boundary points (the hand, the goal)
  forced: [[x, y, z], ...]         # optional waypoints to pass within the threshold
  obstacles:                       # optional spheres no waypoint may enter
    - {centre: [x, y, z], radius: 0.02}
  options: {threshold: 0.003, rounds: 10, smoothing: 0, distortion: 0, margin: 0}
Command-line --threshold/--rounds/--smoothing override 'options'.  Without -o the CSV goes to
stdout and the summary to stderr."""

TASK_FIELDS = ("hila_task", "icps", "forced", "obstacles", "options")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("template", metavar="TEMPLATE.yaml", help="template to imitate")
    parser.add_argument("--task", required=True, metavar="TASK.yaml", help="task scene: ICPs, forced waypoints, obstacles")
    parser.add_argument("--sub", metavar="TAG", default=None, help="imitate only the sub-template with this tag")
    parser.add_argument("-o", "--output", type=output_path, metavar="OUT.csv", default=None, help="CSV to write (default: stdout)")
    parser.add_argument("--threshold", type=float, default=None,
                        help="distortion threshold (task units; default 2 sigma of the template's position noise)")
    parser.add_argument("--timing", type=float, default=None,
                        help="prior spread of when the task passes an ICP on the template path, a fraction "
                             "of the duration (default 0.03; 0 keeps the template's timing)")
    parser.add_argument("--rounds", type=int, default=None, help="max plan-adjustment rounds")
    parser.add_argument("--smoothing", type=float, default=None, help="TPS regulariser (0 = exact)")


def load_task(path, dim: int) -> dict:
    """Read and check a task YAML (format in ``hila imitate --help``)."""
    # lazy: loads numpy, which importing this module does not
    from ..osila import OPTIONS, PER_STEP

    doc = load_yaml(path, "task", unique_keys=True)
    if not isinstance(doc, dict):
        got = "an empty file" if doc is None else type(doc).__name__
        raise InputError(f"expected a task mapping with 'icps:', got {got}", file=str(path))
    for key in doc:
        if key not in TASK_FIELDS:
            close = difflib.get_close_matches(str(key), TASK_FIELDS, 1)
            raise InputError(
                f"unknown field {key!r} in task; expected: {', '.join(TASK_FIELDS)}",
                file=str(path), hint=f"did you mean {close[0]!r}?" if close else None,
            )
    if doc.get("hila_task", 1) != 1:
        raise InputError(f"unsupported task version in field 'hila_task': expected 1, got {doc['hila_task']!r}", file=str(path))
    icps = doc.get("icps")
    if not isinstance(icps, dict) or not icps:
        raise InputError("expected field 'icps' as a non-empty mapping name -> point", file=str(path))
    for name, point in icps.items():
        if not isinstance(name, str):
            raise InputError(f"expected ICP names as strings in field 'icps', got {name!r}", file=str(path))
        if not (isinstance(point, list) and len(point) == dim):
            raise InputError(f"expected field 'icps.{name}' as {dim} numbers (the template's D), got {point!r}", file=str(path))
    options = doc.get("options") or {}
    if not isinstance(options, dict):
        raise InputError("expected field 'options' as a mapping", file=str(path))
    for key in options:
        if key not in OPTIONS or key in PER_STEP:
            raise InputError(f"unknown option {key!r} in field 'options'; expected: threshold, rounds, smoothing, "
                             "distortion, margin, shells, directions, timing", file=str(path))
    return {"icps": icps, "forced": doc.get("forced"), "obstacles": doc.get("obstacles"), "options": dict(options)}


def run(args: argparse.Namespace) -> int:
    # lazy: loads numpy, which importing this module does not
    import numpy as np

    from ..hierarchy.generate import generate
    from ..osila.demofile import demo_csv
    from ..osila.template import END, START, load_template
    from ..core.validation import check_int, check_positive

    template = load_template(args.template)
    step = template
    if args.sub is not None:
        if args.sub not in template.tags():
            close = difflib.get_close_matches(args.sub, template.tags(), 1)
            raise InputError(
                f"template has no sub-template {args.sub!r}; tags: {', '.join(template.tags()) or 'none'}",
                file=args.template, hint=f"did you mean {close[0]!r}?" if close else None,
            )
        step = template.sub(args.sub)
    task = load_task(args.task, step.dim)
    if args.output:
        ensure_writable(args.output)  # a bad -o is refused before the work
    known = set(step.icps) | {START, END}
    for name in task["icps"]:
        if name not in known:
            close = difflib.get_close_matches(name, sorted(known), 1)
            raise InputError(
                f"task ICP {name!r} is not an ICP of template {step.name!r} ({', '.join(step.icps)})",
                file=args.task, hint=f"did you mean {close[0]!r}?" if close else None,
            )
    options = task["options"]
    # command-line overrides, checked here so that an error names the option, not TASK.yaml
    if args.threshold is not None:
        options["threshold"] = check_positive(args.threshold, "--threshold", allow_zero=True)
    if args.rounds is not None:
        options["rounds"] = check_int(args.rounds, "--rounds", minimum=1)
    if args.smoothing is not None:
        options["smoothing"] = check_positive(args.smoothing, "--smoothing", allow_zero=True)
    if args.timing is not None:
        options["timing"] = check_positive(args.timing, "--timing", allow_zero=True)

    options = check_osila_options(options, lambda name: f"option {name!r} (task {args.task} or --{name})")
    try:
        gen = generate(
            [step], task["icps"], forced={0: task["forced"]} if task["forced"] is not None else None,
            obstacles=task["obstacles"], **options,
        )
    except InputError as exc:
        exc.file = exc.file or args.task
        raise
    piece = gen.pieces[0]
    path = gen.path
    text = demo_csv(path, gen.times)
    out = sys.stdout
    if args.output:
        atomic_write_text(args.output, text)
    else:
        sys.stdout.write(text)
        out = sys.stderr
    lines = [
        f"imitated {step.name!r}: {len(path)} points, D = {path.shape[1]}, warp {piece.warp}, "
        f"threshold {piece.threshold:.4g}, {piece.rounds} round(s), {piece.added} constraint pair(s) added",
    ]
    if task["forced"] is not None:
        forced = np.asarray(task["forced"], float).reshape(-1, path.shape[1])
        for i, f in enumerate(forced):
            lines.append(f"  forced waypoint {i}: passed at distance {np.linalg.norm(path - f, axis=1).min():.4g}")
    if args.output:
        lines.append(f"wrote {args.output}")
    print("\n".join(lines), file=out)
    return 0
