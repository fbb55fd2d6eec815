"""``hila learn``: one demonstration -> a segmented template YAML.

The demonstration comes from a CSV path plus its ICPs (learned by
:func:`hila_lang.hierarchy.learn.learn_files`, the function the studio and the letters world call
too), or is seen through the iCub's stereo cameras (:mod:`hila_lang.perception.learn`): recorded
frames (``--frames``, ``--left/--right``) or a recording made in simulation (``--from-sim``), or is
a pen on the printed sheet before one camera (``VIDEO --sheet``, :mod:`hila_lang.perception.pen`):
tracked, written as a demonstration CSV with its pen column and its ICPs, and learned from them as
from any CSV.
"""

from __future__ import annotations

import argparse

from ..core.argtypes import number, output_path, seed, whole
from ..core.errors import InputError
from ..core.fileio import atomic_write_text, ensure_writable
from ..plugins import registry
from ..recognition import require

HELP = "learn a template from one demonstration (CSV path + ICPs), segmented and tagged"
DESCRIPTION = """\
Learn a template from ONE demonstration and store it as human-readable YAML.

Sources (one of):
  DEMO.csv --icps ICPS.yaml   a path and its scene ICPs, as numbers
  --from-sim                  record the seeded demonstration in PyBullet through the iCub's
                              eye cameras, then learn it by perception (about a minute)
  --frames REC                a recording folder (left/, right/, calibration/, cameras.yaml)
  --left L --right R          left and right frames: image folders or video files
  VIDEO --sheet               a pen with a coloured ball on its tip drawing on the sheet 'hila sheet'
                              prints, filmed by one camera (a video file or a folder of frames):
                              see docs/camera.md and "a pen on the printed sheet" below
--from-sim, --frames and --left/--right learn in the world --world names (default tictactoe): the world declares how its
demonstration is recorded and how its scene's ICPs are read (WorldInfo.recorder, .icp_reader).

DEMO.csv: a header line, then one row per waypoint.  Header 't,x,y', 't,x,y,z', 'x,y' or 'x,y,z'
(t in seconds, strictly increasing; x, y, z in metres), optionally with a last column 'pen': 1
where the pen touches the surface, 0 where it is up (a drawing's pointer down/up; what hila
studio and a camera demonstration record).  Blank lines and lines starting with '#' are skipped.
ICPS: the demonstration scene's invariant control points, a YAML mapping 'name: [x, y, z]'
(or a task YAML with an 'icps:' mapping).
The path is split into k contiguous segments, tagged in time order with --tags; --contact names
the tags that touch the surface (drawing).  Where the cuts go (--method):
  contact   where the recorded pen touches and leaves the paper: the default for a demonstration
            with a 'pen' column (the k-1 pen changes that make each tag's contact flag agree with
            the pen at the most samples; without --contact the tags alternate, and those mostly
            pen-down touch)
  speed     the k-1 deepest dips in the hand's speed (where one stroke ends and the next begins;
            bench/segmentation.py measures it): the default without a pen column
  kmeans    the paper's k-means; changepoint (change points of the velocity); equal (equal lengths)
--cuts A,B,... puts the k-1 cuts at those samples (as printed, or as moved by hand in hila
studio), so a template cut by hand is remade by one command.
Example: hila learn demo.csv --icps scene.yaml -k 3 --tags reach,draw,retract --contact draw \\
-o primitives/circle.yaml

With --library DIR the demonstration is first searched for the parts DIR's templates already
hold (each template and its tagged sub-templates), wherever, however big, turned or fast they
were made; known parts are copied from the library (with provenance in the description), the
rest become new segments (tagged new1, new2, ... or by --tags, one per new part).  --report
FILE.json writes every part: {"segments": [{"start", "end", "template", "tag", "distance"}]}.
Without --icps a CSV demonstration's own ends are its ICPs (start, end; said when used): recognition
needs only the path.  See docs/recognition.md.
Example: hila learn demo2.csv --icps scene.yaml --library primitives --report parts.json -o demo2.yaml

A pen on the printed sheet (VIDEO --sheet): the sheet's markers give the paper's plane, the ball
gives the tip and, from its apparent size, its height: the pen is down where the tip is on the
paper, the moments it lands and leaves from the dips in the hand's speed.  The path is in the
sheet's frame (metres from its bottom-left corner: x right, y up the page, z off the paper),
resampled at 20 Hz, and written beside OUT.yaml as OUT.demo.csv (t,x,y,z,pen) with its ICPs as
OUT.icps.yaml; the template is learned from those two files exactly as 'hila learn OUT.demo.csv
--icps OUT.icps.yaml' would.  ICPs: the corners of the printed grid's cell --cell N, or --icps
FILE (sheet frame, metres), or by default the corner markers' centres (tl, tr, br, bl); 'hand'
is where the pen starts unless the ICPs name it.  A video without the sheet's markers, without
the ball, or where the sheet is hidden longer than --max-gap frames is refused (exit 2) and
nothing is written.
Example: hila learn pen.mp4 --sheet --cell 5 -k 3 --tags reach,draw,retract --contact draw -o circle.yaml"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("demo", metavar="DEMO.csv", nargs="?", help="demonstrated path (header t,x,y[,z] or x,y[,z])")
    parser.add_argument("--icps", metavar="ICPS.yaml", help="scene ICPs of DEMO.csv: name: [x, y, z] (with --library: "
                                                            "default its own ends, start and end)")
    seen = parser.add_argument_group("learning by perception (stereo eye cameras)")
    seen.add_argument("--from-sim", action="store_true", help="record the demonstration in PyBullet and learn it by perception")
    seen.add_argument("--keep-recording", metavar="DIR", help="with --from-sim: keep the recorded frames in DIR")
    parser.add_argument("--robot", metavar="NAME|PATH", default=None,
                        help="with --from-sim: the robot whose eyes watch (icub, panda, kuka, a spec .yaml or a "
                             ".urdf; default icub): the iCub's head or the arm's stereo rig (docs/robots.md)")
    parser.add_argument("--set", dest="robot_settings", action="append", default=[], metavar="robot.KEY=VALUE",
                        help="with --robot PATH.urdf: robot.tip=LINK, robot.packages=DIR[:DIR]")
    seen.add_argument("--frames", metavar="REC", help="a recording folder (left/, right/, calibration/, cameras.yaml)")
    seen.add_argument("--left", metavar="L", help="left frames: an image folder or a video file")
    seen.add_argument("--right", metavar="R", help="right frames: an image folder or a video file")
    seen.add_argument("--calibration-left", metavar="F", help="left calibration YAML or chessboard image folder")
    seen.add_argument("--calibration-right", metavar="F", help="right calibration YAML or chessboard image folder")
    seen.add_argument("--cameras", metavar="cameras.yaml", help="camera poses and image size")
    seen.add_argument("--stereo", metavar="DIR", help="chessboard pairs seen by both eyes (left/, right/)")
    seen.add_argument("--world", default="tictactoe", metavar="NAME",
                      help="the world whose demonstration is recorded (--from-sim) or whose scene ICPs are read "
                           "in the frames (default tictactoe, the only one shipped that has them)")
    seen.add_argument("--max-gap", type=int, default=3, help="longest marker loss bridged, frames (default 3)")
    pen = parser.add_argument_group("a pen on the printed sheet before one camera (docs/camera.md)")
    pen.add_argument("--sheet", action="store_true", help="DEMO is a video (or folder of frames) of a pen on the sheet")
    pen.add_argument("--cell", type=whole(1, 9, " (1 top left, 9 bottom right as you read the sheet)"), default=None,
                     metavar="N",
                     help="ICPs tl, tr, br, bl: the corners of the printed grid's cell N (1 top left .. 9)")
    pen.add_argument("--ball", default="green", metavar="COLOUR",
                     help="colour of the ball on the pen's tip: green (default), blue, red, yellow, cyan, magenta")
    pen.add_argument("--ball-mm", type=number(2, 60, " mm"), default=12.0, metavar="MM",
                     help="the ball's diameter (default 12 mm)")
    pen.add_argument("--hfov", type=number(20, 150, " degrees"), default=None, metavar="DEG",
                     help="the camera's horizontal field of view, if known (else measured from the sheet)")
    pen.add_argument("--fps", type=number(1, 1000), default=30.0, help="frame rate of a folder of frames (default 30)")
    parser.add_argument("-k", type=int, default=None, help="number of segments (default: number of --tags, or 1)")
    parser.add_argument("--tags", default=None, help="comma-separated segment tags in time order")
    parser.add_argument("--contact", default="", help="comma-separated tags that touch the surface")
    parser.add_argument("--method", choices=("contact", "speed", "kmeans", "changepoint", "equal"), default=None,
                        help="segmentation: contact (where the recorded pen touches and leaves the paper; the "
                             "default when DEMO.csv has a 'pen' column), speed (the deepest dips in speed, where "
                             "the hand slows between strokes; the default otherwise), kmeans (the paper's: "
                             "k-means on position and time), changepoint (change points of the velocity), equal "
                             "(equal lengths)")
    parser.add_argument("--cuts", default=None, metavar="A,B,...",
                        help="the k-1 cuts as sample indices (each the first sample of the next tag), instead of "
                             "a --method: a template cut by hand, remade by one command")
    parser.add_argument("--seed", type=seed, default=0, help="k-means seed (default 0)")
    parser.add_argument("--name", default=None, help="template name (default: the output file's stem)")
    parser.add_argument("--description", default=None, help="provenance text stored in the template")
    known = parser.add_argument_group("recognition of known parts (docs/recognition.md)")
    known.add_argument("--library", metavar="DIR", help="find DIR's templates and sub-templates in the demonstration")
    known.add_argument("--report", type=output_path, metavar="FILE.json", help="with --library: write the parts found as JSON")
    known.add_argument("--stream", action="store_true",
                       help="with --library: feed the demonstration point by point and say each known part as soon as "
                            "it is found (online recognition); the final answer is the offline one")
    parser.add_argument("-o", "--output", type=output_path, required=True, metavar="OUT.yaml", help="template file to write")


def _split(text: str | None, option: str = "--tags") -> list[str]:
    """Comma-separated tags, each one a name a program can write (``run TEMPLATE.TAG(...)``)."""
    # lazy: loads lark, which importing this module does not
    from ..language.transformer import usable_as_tag

    if not text:
        return []
    tags = [t.strip() for t in text.split(",")]
    for i, tag in enumerate(tags, start=1):
        if not tag:
            raise InputError(f"{option} {text}: tag {i} is empty", hint="separate the tags with single commas")
        if not usable_as_tag(tag):
            fixed = "_".join(filter(None, "".join(c if c.isalnum() or c == "_" else " " for c in tag).split()))
            fixed = fixed if fixed[:1].isalpha() or fixed[:1] == "_" else f"_{fixed}"
            raise InputError(
                f"{option} {text}: {tag!r} cannot be written in a program (run TEMPLATE.{tag}(...)): a tag is a "
                "letter or '_' and then letters, digits or '_'",
                hint=f"e.g. {fixed!r}" if fixed and usable_as_tag(fixed) else None)
    return tags


def _source(args: argparse.Namespace) -> str:
    """Which demonstration source the arguments name; exactly one is allowed."""
    if getattr(args, "sheet", False):
        others = [name for name, on in (("--from-sim", args.from_sim), ("--frames", args.frames is not None),
                                        ("--left/--right", args.left is not None or args.right is not None),
                                        ("--keep-recording", args.keep_recording),
                                        ("--robot/--set", args.robot is not None or args.robot_settings)) if on]
        if args.demo is None or others:
            raise InputError("--sheet learns from one video: hila learn VIDEO --sheet"
                             + (f" (not with {' and '.join(others)})" if others else ""))
        return "--sheet"
    if getattr(args, "cell", None) is not None:
        raise InputError("--cell goes with --sheet (the printed grid's cell)")
    given = [name for name, on in (
        ("DEMO.csv", args.demo is not None),
        ("--from-sim", args.from_sim),
        ("--frames", args.frames is not None),
        ("--left/--right", args.left is not None or args.right is not None),
    ) if on]
    if len(given) != 1:
        got = "none" if not given else " and ".join(given)
        raise InputError(f"expected one demonstration source (DEMO.csv, --from-sim, --frames or --left/--right), got {got}")
    source = given[0]
    if source == "DEMO.csv" and args.icps is None and args.library is None:
        raise InputError("DEMO.csv needs its scene ICPs: add --icps ICPS.yaml",
                         hint="with --library the demonstration's own ends serve (start, end)")
    if source != "DEMO.csv" and args.icps is not None:
        raise InputError(f"--icps goes with DEMO.csv; {source} finds the ICPs in the images")
    if source == "--left/--right" and (args.left is None or args.right is None):
        raise InputError("expected both --left and --right frames")
    if source != "--from-sim" and args.keep_recording:
        raise InputError("--keep-recording goes with --from-sim")
    if source != "--from-sim" and (args.robot is not None or args.robot_settings):
        raise InputError("--robot and --set robot.KEY go with --from-sim (the robot whose eyes watch)")
    # lazy: loads numpy, which importing this module does not
    from ..robot.spec import robot_pairs

    robot_pairs(args.robot_settings, "hila learn")
    return source


def _from_sheet(args: argparse.Namespace, out) -> tuple[str, str]:
    """Track the pen in the video ``args.demo`` (:mod:`hila_lang.perception.pen`), write
    OUT.demo.csv (t,x,y,z,pen at 20 Hz) and OUT.icps.yaml beside ``out``; returns their paths."""
    # lazy: loads numpy, which importing this module does not
    from ..osila.demofile import demo_csv, load_icps, write_icps
    from ..evaluation.lasa import RATE_HZ
    from ..perception.pen import as_demonstration, track_video

    stem = out.name[:-len(out.suffix)] if out.suffix else out.name
    csv, icps_file = out.with_name(f"{stem}.demo.csv"), out.with_name(f"{stem}.icps.yaml")
    for path in (csv, icps_file):
        ensure_writable(path)
    given = load_icps(args.icps, 3) if args.icps else None
    print(f"tracking the pen in {args.demo} ...", flush=True)
    track = track_video(args.demo, ball=args.ball, ball_mm=args.ball_mm, hfov_deg=args.hfov, fps=args.fps,
                        max_gap=args.max_gap, progress=lambda n: print(f"  {n} frames", flush=True))
    path, times, pen, icps = as_demonstration(track, RATE_HZ, given, args.cell)
    print(f"  {track.summary()}")
    atomic_write_text(csv, f"# tracked by hila learn --sheet from {args.demo}: {track.summary()}\n"
                           "# sheet frame, metres: x right, y up the page, z off the paper; pen 1 = on the paper\n"
                      + demo_csv(path, times, pen))
    write_icps(icps_file, icps,
               header=f"ICPs of {csv.name}: the {track.layout.name} sheet's frame, metres")
    return str(csv), str(icps_file)


def _perceived(args: argparse.Namespace, source: str, k: int, tags: list[str], contact: list[str], name: str):
    """The template learned through the eye cameras (imports OpenCV and PyBullet)."""
    # lazy: loads numpy, which importing this module does not
    from ..perception.learn import template_from_frames

    info = registry.world(args.world)
    if source == "--from-sim":
        learn_from_sim = info.capability("recorder", "demonstration to record", "--from-sim")
        extra = {}
        if args.robot is not None:  # a recorder that takes the robot (a world's own may not): hila_lang.robot.spec
            # lazy: loads numpy, which importing this module does not
            from ..robot.spec import resolve, robot_pairs

            extra["robot"] = resolve(args.robot, robot_pairs(args.robot_settings, "hila learn"))
        who = "the iCub's eye cameras" if args.robot is None else f"the {extra['robot'].name}'s cameras"
        print(f"recording the demonstration through {who} (about a minute) ...", flush=True)
        template = learn_from_sim(args.seed, k=k, tags=tags, contact=contact, name=name, method=args.method,
                                  recording_dir=args.keep_recording, **extra)
    else:
        left, right = (args.frames, None) if source == "--frames" else (args.left, args.right)
        demonstration_icps = info.capability("icp_reader", "reader of a demonstration's ICPs", source)
        template = template_from_frames(
            left, right, read_icps=demonstration_icps, calibration_left=args.calibration_left, calibration_right=args.calibration_right,
            cameras=args.cameras, stereo=args.stereo, k=k, tags=tags, contact=contact, name=name,
            method=args.method, seed=args.seed, max_gap=args.max_gap)
    if args.description:
        template.description = args.description
    return template


def _library(args: argparse.Namespace):
    """(templates by name, searchable parts) of --library, or None; refuses --report without it."""
    if args.library is None:
        for option, on in (("--report", args.report), ("--stream", args.stream)):
            if on:
                raise InputError(f"{option} goes with --library: add --library DIR")
        return None
    if args.k is not None:
        raise InputError("-k does not go with --library: the parts are what the library recognises",
                         hint="--tags names the new parts, one tag each")
    # lazy: loads numpy, which importing this module does not
    from ..recognition.library import load_library

    require()
    templates, entries = load_library(args.library)
    return {t.name: t for t in templates}, entries


def _streamed(template, entries):
    """Online recognition of ``template``'s path fed point by point; prints each event; the final parts."""
    # lazy: loads numpy, which importing this module does not
    import numpy as np

    from ..recognition.online import OnlineRecogniser

    times = template.times if template.times is not None else np.arange(len(template.path)) / 20.0
    online = OnlineRecogniser(entries)

    def say(events):
        for e in events:
            p = e.part
            name = p.template if p.tag is None else f"{p.template}.{p.tag}"
            print(f"  at {e.at:6.2f} s: {e.kind:<9} {name}  samples [{p.start}, {p.end}), ended {times[p.end - 1]:.2f} s",
                  flush=True)

    print("streaming the demonstration point by point:")
    for point, t in zip(template.path, times):
        say(online.push(point, float(t)))
    final, corrections = online.finish()
    say(corrections)
    print(f"end of stream: {len(corrections)} correction(s) by the final, offline answer")
    return final


def _recognised(template, library, tags: list[str], contact: list[str], report, stream: bool = False):
    """``template`` cut into the library's known parts and new parts; prints them, writes the report."""
    # lazy: loads numpy, which importing this module does not
    from ..recognition.search import recognise
    from ..recognition.written import recognised_template, write_report

    by_name, entries = library
    parts = _streamed(template, entries) if stream else recognise(template.path, entries, template.times)
    out = recognised_template(template, parts, by_name, tags, contact)
    other = sum(e.dim != template.dim for e in entries)
    skipped = f" ({other} of another dimension than the demonstration's {template.dim}-D not searched)" if other else ""
    print(f"recognised against {len(by_name)} template(s), {len(entries)} part(s){skipped}:")
    for part, seg in zip(parts, out.segments):
        span = f"{part.t_start:.2f}-{part.t_end:.2f} s, samples [{part.start}, {part.end})"
        if part.known:
            name = part.template if part.tag is None else f"{part.template}.{part.tag}"
            print(f"  known  {seg.tag:<10} {span}  = {name}  distance {part.distance:.3f}  confidence {part.confidence:.2f}")
        else:
            print(f"  new    {seg.tag:<10} {span}")
    if report is not None:
        write_report(report, parts)
        print(f"report -> {report}")
    return out


def _cuts(text: str | None) -> list[int] | None:
    """``--cuts A,B,...`` as sample indices (checked against k and the path by
    :func:`hila_lang.hierarchy.learn.check_cuts`)."""
    if text is None:
        return None
    try:
        return [int(c) for c in text.split(",")]
    except ValueError:
        raise InputError(f"--cuts {text}: expected sample indices separated by commas, e.g. --cuts 25,57") from None


def _point(p) -> str:
    return "(" + ", ".join(f"{float(v):.4g}" for v in p) + ")"


def run(args: argparse.Namespace) -> int:
    # lazy: loads numpy, which importing this module does not
    from ..hierarchy.learn import default_tags, learn_files
    from ..osila.template import save_template

    source = _source(args)
    k, tags = default_tags(_split(args.tags), args.k)
    contact = _split(args.contact, "--contact")
    library = _library(args)  # a bad library stops before anything is made or written
    out = ensure_writable(args.output)  # before the work: learning by perception takes a minute
    report = ensure_writable(args.report) if args.report else None
    name = args.name or out.stem
    if library is not None:
        (tags_new, tags), (contact_new, contact), k = (tags, []), (contact, []), 1
        if args.cuts is not None:
            raise InputError("--cuts does not go with --library: the parts are what the library recognises")
    if source == "--sheet":
        args.demo, args.icps = _from_sheet(args, out)
        source = "DEMO.csv"
    if source != "DEMO.csv":
        if args.cuts is not None:
            raise InputError(f"--cuts goes with DEMO.csv; {source} is cut by --method")
        args.method = args.method or "speed"
        template = _perceived(args, source, k, tags or ["s1"], contact, name)
    else:
        template = learn_files(args.demo, args.icps, name=name, tags=tags, contact=contact, k=k, method=args.method,
                               seed=args.seed, description=args.description or None, cuts=_cuts(args.cuts))
        if args.icps is None:  # only with --library (_source): recognition needs no scene, only the path
            ends = template.icps
            print(f"no --icps: the demonstration's own ends are its ICPs: start {_point(ends['start'])}, "
                  f"end {_point(ends['end'])}")
    if library is not None:
        template = _recognised(template, library, tags_new, contact_new, report, args.stream)
    save_template(template, out)
    print(f"learned template {name!r}: {len(template.path)} points, D = {template.path.shape[1]}, "
          f"{len(template.icps)} ICPs -> {out}")
    for seg in template.segments:
        flag = " (contact)" if seg.contact else ""
        print(f"  {seg.tag:<12} [{seg.start}, {seg.stop}){flag}")
    return 0
