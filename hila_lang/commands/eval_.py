"""``hila eval``: is one demonstration worth anything?  OSILA against controls on the same constraints."""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from ..core.argtypes import number, output_path, seed, TRIALS_PER_SETUP_MAX, whole
from ..core.errors import InputError
from ..core.fileio import OutputFolder
from ..core.interrupts import cause, joblib_workers_ignoring_sigint
from ..core.resources import clamp_jobs

HELP = "evaluate OSILA against controls, baselines and its own ablation on the same constraints"
DESCRIPTION = """\
Every trial's path (the template) is imitated under another trial's constraints (the task) and
compared with the task's own human path.  Every method gets exactly the same constraints:
OSILA; the controls none (a spline through the anchor points), similarity (the template moved
rigidly), tps (the bare warp), dmp and dmp-aligned; the baselines promp, laplacian (Laplacian
trajectory editing) and gp, each also +retime (with OSILA's re-timing); and OSILA's ablation
osila-noroute, -noretime, -noadjust, -tps, -similarity, -nopath (no path warp), -retimeall
(every on-path pair re-timed, as if timed) and -fixedlimit (the former amplification limit).
Printed: per method and N, mean Frechet and DTW (time-free) and MSD where no timing is given
away; methods identical to another on every pair, once; then tests over shapes (Wilcoxon,
median difference with a bootstrap CI, shapes won / tied / lost): the CONFIRMATORY family
declared in advance -- Frechet, OSILA against each baseline, N >= 2 (N = 1 where the protocol
has no other) -- Holm-corrected within it; every other test printed as exploratory (raw p).

Protocols (what a method is told about the task):
  held-out   (default) the task's scene ICPs only (hand start, object corners, waypoint area),
             nothing from the path that is scored; N = 1
  positions  leak-free: scene ICPs (if any) plus the task path's points at arc-length fractions
             k/N (N = 1..4) -- positions only, never when the person passed them; LASA default
  paper      the paper's Experiment A: scene ICPs plus, for N = 2..4 equal segments, each inner
             boundary of the TASK PATH as a constraint; also prints Tables I-III in the paper's
             layout with the paper's figures beside ours (reference only: their data is not public)
  fractions  LASA: the task's points at TIME fractions k/N (time leaks into MSD at N >= 2)

Data:
  (default)         a seeded STAND-IN for the paper's 75 human trials (5 set-ups x 15 human-like
                    reaches following its Fig. 5, image pixels), saved to OUT/dataset
  --dataset lasa    LASA human handwriting (pip install 'hila-lang[lasa]'): every ordered pair of
                    the 7 demonstrations of a shape, constraints at arc-length fractions k/N of the
                    task (N = 1..4); --shapes picks the shapes (default: the 14-shape development
                    set; held-back: the other 16)
  --dataset FOLDER  your trials: FOLDER/<set-up>/<trial>.csv (header t,x,y[,z] or x,y[,z]) and
                    <trial>.icps.yaml beside it ('name: [x, y]'); paired on shared ICP names

Writes tables.txt, pairs.csv, results.json (summary and tests rows; byte-identical for the same
seed), timings.json and heatmaps to --out."""

DEFAULT_METHODS = ("osila", "none", "similarity", "tps", "dmp", "dmp-aligned",
                   "promp", "promp+retime", "laplacian", "laplacian+retime", "gp", "gp+retime",
                   "osila-noroute", "osila-noretime", "osila-noadjust", "osila-tps", "osila-similarity",
                   "osila-nopath", "osila-retimeall", "osila-fixedlimit")
#: the defaults that need movement_primitives (the 'peers' extra)
PEERS = ("dmp", "dmp-aligned", "promp", "promp+retime")


def _jobs(text: str) -> int:
    value = whole(-1)(text)
    if value == 0:
        raise argparse.ArgumentTypeError("expected --jobs >= 1 or -1 (all cores), got 0")
    return value


def _methods(text: str) -> tuple[str, ...]:
    # lazy: loads numpy, which importing this module does not
    from ..evaluation.grid import METHODS

    names = tuple(m.strip() for m in text.split(",") if m.strip())
    unknown = [m for m in names if m not in METHODS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown method {unknown[0]!r}; expected a comma list of {', '.join(METHODS)}" if unknown
            else "expected at least one method")
    return names


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=output_path, default="eval-results", metavar="DIR",
                        help="folder for tables.txt, pairs.csv, results.json, heatmaps (default: eval-results)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--jobs", type=_jobs, default=1, metavar="N",
                       help="worker processes (joblib); -1 = all cores (default 1)")
    where.add_argument("--dask", default=None, metavar="ADDRESS",
                       help="run on a Dask distributed scheduler, e.g. tcp://host:8786")
    parser.add_argument("--dataset", default=None, metavar="FOLDER|lasa",
                        help="'lasa' for the LASA handwriting set, or a folder of your own trials (format "
                             "above); default: the generated stand-in")
    parser.add_argument("--protocol", choices=("held-out", "paper", "positions", "fractions"), default=None,
                        help="what a method is told about the task (default: held-out; LASA: positions); "
                             "positions and fractions for LASA, held-out, paper and positions for data with ICPs")
    parser.add_argument("--shapes", default=None, metavar="LIST",
                        help="LASA only: 'dev' (the 14-shape development set, default), 'held-back' (the other "
                             "16), 'all', or NAME,NAME")
    parser.add_argument("--methods", type=_methods, default=None, metavar="LIST",
                        help="comma list of methods (default: " + ",".join(DEFAULT_METHODS) +
                             "; dmp, dmp-aligned and promp need pip install 'hila-lang[peers]'); 'hila' adds the "
                             "per-segment hierarchical generator (paper protocol)")
    parser.add_argument("--hila", action="store_true", help="shorthand: add the method 'hila'")
    parser.add_argument("--trials-per-setup", type=whole(1, TRIALS_PER_SETUP_MAX), default=None, metavar="N",
                        help=f"stand-in only: trials per set-up (default 15, as in the paper; at most {TRIALS_PER_SETUP_MAX})")
    parser.add_argument("--seed", type=seed, default=0, help="stand-in only: dataset seed (default 0)")
    parser.add_argument("--threshold", type=number(0), default=None, metavar="D",
                        help="OSILA distortion threshold in path units (default: 2 px for the stand-in as "
                             "in the paper; OSILA's own default, 2 sigma of the template's position noise, "
                             "otherwise)")
    parser.add_argument("--timing", type=number(0), default=None, metavar="S",
                        help="OSILA's prior spread of when the task passes an ICP on the template path, a "
                             "fraction of the duration (default 0.03; 0 keeps the template's timing); the +retime "
                             "baselines use it too.  Only pairs that carry the task's time are re-timed (paper, "
                             "fractions)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def _data(args: argparse.Namespace, out: Path):
    """(trials, source text, protocol, pair mask, threshold) for the chosen data set."""
    # lazy: loads numpy, which importing this module does not
    from ..evaluation import dataset as ds
    from ..evaluation.protocols import pair_mask

    if args.dataset is not None and args.trials_per_setup is not None:
        raise InputError("--trials-per-setup applies to the generated stand-in, not to --dataset")
    if args.shapes is not None and args.dataset != "lasa":
        raise InputError("--shapes applies to --dataset lasa")
    if args.dataset == "lasa":
        # lazy: loads numpy, which importing this module does not
        from ..evaluation import lasa

        if args.protocol not in (None, "positions", "fractions"):
            raise InputError(f"--protocol {args.protocol} is for data with scene ICPs; LASA has none, its "
                             "constraints are the task's points at arc-length (positions, the default) or time "
                             "(fractions) fractions k/N")
        shapes = lasa.resolve_shapes(args.shapes)
        trials = lasa.load(shapes)
        label = ("the development set" if shapes == lasa.DEVELOPMENT else "the held-back shapes"
                 if shapes == lasa.held_back() else "all shapes" if len(shapes) == 30 else "shapes")
        source = (f"LASA handwriting, {label}: {', '.join(shapes)} ({len(trials)} demonstrations at "
                  f"{lasa.RATE_HZ:g} Hz; pairs of different demonstrations of a shape)")
        return trials, source, args.protocol or "positions", pair_mask(trials, within_setup_only=True), args.threshold
    protocol = args.protocol or "held-out"
    if protocol == "fractions":
        raise InputError("--protocol fractions is for --dataset lasa (data without scene ICPs); use positions")
    if args.dataset is not None:
        trials = ds.load_dataset(args.dataset)
        source = f"dataset {args.dataset}"
        threshold = args.threshold
    else:
        per = 15 if args.trials_per_setup is None else args.trials_per_setup
        trials = ds.generate(seed=args.seed, trials_per_setup=per)
        source = f"stand-in (seed {args.seed}, {per} trials per set-up; the paper's human data is not public)"
        threshold = 2.0 if args.threshold is None else args.threshold
        ds.save_dataset(trials, out / "dataset")
    return trials, source, protocol, pair_mask(trials, within_setup_only=False), threshold


def _chosen_methods(args: argparse.Namespace, protocol: str) -> tuple[str, ...]:
    # lazy: loads numpy, which importing this module does not
    from ..evaluation.controls import dmp_available

    methods = args.methods
    if methods is None:
        methods = DEFAULT_METHODS if dmp_available() else tuple(m for m in DEFAULT_METHODS if m not in PEERS)
        if not dmp_available():
            print("note: the DMP controls and the ProMP baseline need movement_primitives (pip install "
                  "'hila-lang[peers]'); running without dmp, dmp-aligned, promp and promp+retime", file=sys.stderr)
    if args.hila and "hila" not in methods:
        methods = methods + ("hila",)
    if "hila" in methods and protocol != "paper":
        raise InputError("the method 'hila' binds each segment's end to the task path's boundary point, "
                         "so it needs --protocol paper")
    return methods


def run(args: argparse.Namespace) -> int:
    args.jobs = clamp_jobs(args.jobs)  # never more workers than cores (issue 20), with a note
    if args.jobs != 1 and args.dask is None:  # first, before numpy starts its threads
        joblib_workers_ignoring_sigint(args.jobs)  # Ctrl-C: exit 130, no worker tracebacks, no hang
    # lazy: loads numpy, which importing this module does not
    from ..evaluation.protocols import segments_for
    from ..evaluation.report import write_report
    from ..evaluation.run import check_scheduler, run_grid
    from ..evaluation.tables import render

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError("expected a folder, got a file", file=str(out))
    if args.dask is not None:
        check_scheduler(args.dask)  # before any data is made or written
    OutputFolder(out, "eval")  # made and proved writable before any data is made
    trials, source, protocol, mask, threshold = _data(args, out)
    methods = _chosen_methods(args, protocol)
    segments = segments_for(protocol)
    options = {} if threshold is None else {"threshold": threshold}
    if args.timing is not None:
        options["timing"] = args.timing
    print(f"hila eval: {len(trials)} trials from the {source}; {int(mask.sum())} pairs x N = "
          f"{','.join(map(str, segments))} x {len(methods)} methods", file=sys.stderr)
    result = run_grid(trials, segments=segments, methods=methods, options=options, protocol=protocol, mask=mask,
                      jobs=args.jobs, dask=args.dask, progress=not args.no_progress)
    # a set-up with no pair scored (a stopped run, every pair failed) is NaN in the tables, as said there
    warnings.filterwarnings("ignore", "Mean of empty slice", RuntimeWarning)
    stopped = ""
    if result.stopped is not None:
        stopped = (f"INCOMPLETE: stopped by {cause(result.stopped)} after {result.rows_done} of {len(trials)} "
                   f"template rows; every figure below is over the {int(result.mask.sum())} pairs done\n\n")
    text = (stopped + f"Data: {source}\nProtocol: {protocol}\nGrid: {int(mask.sum())} pairs x N = "
            f"{', '.join(map(str, segments))}, {result.backend}, {result.wall_seconds:.1f} s\n\n"
            + render(result, tables=args.dataset != "lasa"))
    sys.stdout.write(text)
    info = {"source": source, "threshold": threshold, "timing": args.timing,
            "seed": args.seed if args.dataset is None else None}
    if result.stopped is not None:
        info.update(complete=False, stopped_by=cause(result.stopped), rows_done=result.rows_done,
                    rows=len(trials))
    written = write_report(result, text, out, info)
    for m in methods:
        if result.failures[m]:
            print(f"warning: {len(result.failures[m])} {m} pairs failed (scored NaN); first: "
                  f"{result.failures[m][0]}", file=sys.stderr)
    print(f"wrote {len(written)} files to {out}/ ({', '.join(sorted(Path(w).name for w in written))})",
          file=sys.stderr)
    if result.stopped is not None:  # saved what was done: now end as the signal asked (130, 143, 129)
        print(f"stopped by {cause(result.stopped)}: the files hold the {result.rows_done} of {len(trials)} "
              "template rows done, marked incomplete", file=sys.stderr)
        raise result.stopped
    return 0
