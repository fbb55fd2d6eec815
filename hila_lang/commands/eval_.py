"""``hila eval``: the paper's Experiment A — every trial's template mapped onto every trial."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "Experiment A: 75 x 75 cross-mapping, N = 1..4 segments; the paper's Tables I-III side by side"
DESCRIPTION = """\
Reproduce the paper's Experiment A: every trial's path (template) is imitated under every trial's
constraints (task), unsegmented and with N = 2, 3, 4 equal segments (each inner segment boundary
adds a constraint pair), and compared with the task's own path by R and MSD after cubic-spline
resampling.  Prints Tables I-III in the paper's layout with the paper's figures beside ours, and
the paper's summary shares; writes tables.txt, pairs.csv, results.json and heatmap PNGs to --out.

By default the data is a seeded STAND-IN for the paper's 75 human trials, which are not public
(5 set-ups x 15 human-like paths following the paper's Fig. 5, in image pixels); it is saved to
OUT/dataset in the --dataset format.  --dataset FOLDER evaluates your own demonstrations instead:
FOLDER/<set-up>/<trial>.csv (header t,x,y[,z] or x,y[,z], as for 'hila learn') and
<trial>.icps.yaml beside it ('name: [x, y]'); trials are paired on shared ICP names.
--peers adds a bare TPS warp and DMPs (pip install 'hila-lang[peers]') on the same grid; --hila adds
the per-segment generation of the hierarchical generator (sub-templates imitated one by one, stitched)."""


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def _positive_int(text: str) -> int:
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {value}")
    return value


def _jobs(text: str) -> int:
    value = _integer(text)
    if value < 1 and value != -1:
        raise argparse.ArgumentTypeError(f"expected --jobs >= 1 or -1 (all cores), got {value}")
    return value


def _threshold(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a threshold >= 0, got {text}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="eval-results", metavar="DIR",
                        help="folder for tables.txt, pairs.csv, results.json, heatmaps (default: eval-results)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--jobs", type=_jobs, default=1, metavar="N",
                       help="worker processes (joblib); -1 = all cores (default 1)")
    where.add_argument("--dask", default=None, metavar="ADDRESS",
                       help="run on a Dask distributed scheduler, e.g. tcp://host:8786")
    parser.add_argument("--dataset", default=None, metavar="FOLDER",
                        help="evaluate your own trials (format above) instead of the stand-in")
    parser.add_argument("--peers", action="store_true", help="also run the bare TPS warp and DMPs")
    parser.add_argument("--hila", action="store_true",
                        help="also run the segments through the hierarchical generator (one OSILA per "
                             "segment, stitched) beside the one-OSILA-with-boundary-pairs of the Tables")
    parser.add_argument("--trials-per-setup", type=_positive_int, default=None, metavar="N",
                        help="stand-in only: trials per set-up (default 15, as in the paper)")
    parser.add_argument("--seed", type=int, default=0, help="stand-in only: dataset seed (default 0)")
    parser.add_argument("--threshold", type=_threshold, default=None, metavar="D",
                        help="OSILA distortion threshold in path units (default: 2 px for the stand-in as "
                             "in the paper; OSILA's own default for --dataset)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def run(args: argparse.Namespace) -> int:
    from ..fileio import OutputFolder
    from ..interrupts import joblib_workers_ignoring_sigint

    if args.jobs != 1 and args.dask is None:  # first, before numpy starts its threads
        joblib_workers_ignoring_sigint(args.jobs)  # Ctrl-C: exit 130, no worker tracebacks, no hang
    from ..errors import InputError
    from ..evaluation import dataset as ds
    from ..evaluation.report import write_report
    from ..evaluation.run import check_scheduler, run_grid
    from ..evaluation.tables import render

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError("expected a folder, got a file", file=str(out))
    if args.dask is not None:
        check_scheduler(args.dask)  # before any data is made or written
    OutputFolder(out, "eval")  # made and proved writable before any data is made
    if args.dataset is not None:
        if args.trials_per_setup is not None:
            raise InputError("--trials-per-setup applies to the generated stand-in, not to --dataset")
        trials = ds.load_dataset(args.dataset)
        threshold = args.threshold
        source = f"dataset {args.dataset}"
    else:
        per = 15 if args.trials_per_setup is None else args.trials_per_setup
        trials = ds.generate(seed=args.seed, trials_per_setup=per)
        threshold = 2.0 if args.threshold is None else args.threshold
        source = f"stand-in (seed {args.seed}, {per} trials per set-up; the paper's human data is not public)"
        ds.save_dataset(trials, out / "dataset")
    methods = ("osila",) + (("hila",) if args.hila else ()) + (("tps", "dmp") if args.peers else ())
    options = {} if threshold is None else {"threshold": threshold}
    print(f"hila eval: {len(trials)} trials from the {source}; {len(trials) ** 2 * 4 * len(methods)} generations",
          file=sys.stderr)
    result = run_grid(trials, methods=methods, options=options, jobs=args.jobs, dask=args.dask,
                      progress=not args.no_progress)
    text = f"Data: {source}\nGrid: {len(trials)} x {len(trials)} pairs x N = 1..4, {result.backend}, " \
           f"{result.wall_seconds:.1f} s\n\n" + render(result)
    sys.stdout.write(text)
    info = {"source": source, "threshold": threshold, "seed": args.seed if args.dataset is None else None}
    written = write_report(result, text, out, info)
    for m in methods:
        if result.failures[m]:
            print(f"warning: {len(result.failures[m])} {m} pairs failed (scored NaN); first: "
                  f"{result.failures[m][0]}", file=sys.stderr)
    print(f"wrote {len(written)} files to {out}/ (tables.txt, pairs.csv, results.json, heatmaps)", file=sys.stderr)
    return 0
