"""Benchmark: the whole Experiment A grid — 75 × 75 pairs × N = 1..4 = 22,500 OSILA generations
plus their R and MSD — on the seeded stand-in dataset.

Prints the wall time (target <= 60 s on the 2-core project machine) and the time per generation;
``--peers`` times the bare TPS warp and the DMPs too, ``--hila`` the per-segment variant.  Not a test.

    /work/venv/bin/python bench/eval.py [--jobs 2] [--peers] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import time

from hila_lang.evaluation.dataset import generate
from hila_lang.evaluation.run import run_grid
from hila_lang.evaluation.tables import summary

TARGET_S = 60.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2, help="joblib processes (default 2, the machine's cores)")
    ap.add_argument("--peers", action="store_true", help="also time the TPS and DMP peers")
    ap.add_argument("--hila", action="store_true", help="also time the per-segment (hierarchical) variant")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    trials = generate(seed=args.seed)
    t_data = time.perf_counter() - t0
    methods = ("osila",) + (("hila",) if args.hila else ()) + (("tps", "dmp") if args.peers else ())
    result = run_grid(trials, methods=methods, options={"threshold": 2.0}, jobs=args.jobs, progress=False)
    n_gen = len(trials) ** 2 * len(result.segments)
    print(f"machine: {os.cpu_count()} cores; jobs = {args.jobs}; dataset of {len(trials)} trials in {t_data:.2f} s")
    print(f"grid: {n_gen} generations per method x {len(methods)} method(s) + R and MSD: "
          f"{result.wall_seconds:.1f} s wall (target <= {TARGET_S:.0f} s for OSILA alone)")
    for m in methods:
        per = result.seconds[m]
        print(f"  {m:<6} {1e3 * float(per.mean()):.3f} ms per generation (in-worker, without metrics); "
              f"{1e3 * float(per.sum()):.0f} ms summed")
    for row in summary(result):
        print(f"  {row['label']:<32} ours {100 * row['cells']:.0f}% of cells, {100 * row['pairs']:.0f}% of pairs; "
              f"paper {100 * row['paper_cells']:.0f}% of cells")


if __name__ == "__main__":
    main()
