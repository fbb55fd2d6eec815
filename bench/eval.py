"""Benchmark: the two headline evaluations of ``hila eval``, timed as a user runs them.

1. ``hila eval --dataset lasa --jobs 2``: the 14 LASA development shapes, 588 pairs of different
   demonstrations, N = 1..4, the leak-free ``positions`` protocol, OSILA, the five controls, the
   six baselines and the five ablations (39,984 generations plus every metric): must finish in
   <= 90 s on the 2-core project machine;
2. the same command with only the methods and protocol of the evaluation before issue 25 (OSILA
   and the five controls, ``--protocol fractions``), timed in the same conditions right after: the
   ratio of the two is what the baselines and the ablation cost, whatever else runs on the
   machine (it is shared; the load average is printed before and after);
3. ``hila eval --protocol held-out --jobs 2``: the stand-in, 75 x 75 pairs, N = 1, every method.

Each runs as a fresh command (a new process, so joblib's workers start and load the compiled
kernels as they would for a user); the wall time is printed.  ``--paper`` also times ``--protocol
paper``.  Not a test.

    python bench/eval.py [--jobs 2] [--paper] [--no-held-out]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 90.0
BEFORE = ("osila", "none", "similarity", "tps", "dmp", "dmp-aligned")


def run(label: str, argv: list[str], out: Path) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "eval", *argv, "--out", str(out), "--no-progress"],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        print(f"{label}: failed (exit {proc.returncode})\n{proc.stderr}")
        return float("nan")
    doc = json.loads((out / "results.json").read_text())
    timings = json.loads((out / "timings.json").read_text())
    rows = {(r["method"], r["n"]): r for r in doc["summary"]}
    ms = {(r["method"], r["n"]): r["ms_per_path"] for r in timings["ms_per_path"]}
    grid = timings["wall_seconds"]
    print(f"{label}: {wall:.1f} s wall for the command, {grid:.1f} s in the grid "
          f"({'within' if wall <= TARGET_S else 'OVER'} the {TARGET_S:.0f} s target); "
          f"{doc['run']['pairs']} pairs x N = {doc['run']['segments']} x {len(doc['run']['methods'])} methods")
    for n in doc["run"]["segments"]:
        o = rows[("osila", n)]
        print(f"  N = {n}: OSILA mean MSD {o['msd']:.4g}, Frechet {o['frechet']:.4g}, "
              f"{ms[('osila', n)]:.2f} ms per path")
    return wall


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2, help="joblib processes (default 2, the machine's cores)")
    ap.add_argument("--paper", action="store_true", help="also time --protocol paper")
    ap.add_argument("--no-held-out", action="store_true", help="skip the stand-in's held-out run")
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} cores (shared); jobs = {args.jobs}; {load()}")
    jobs = ["--jobs", str(args.jobs)]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        full = run("LASA (development shapes), every method", ["--dataset", "lasa", *jobs], tmp / "lasa")
        before = run("LASA, the methods and protocol before issue 25",
                     ["--dataset", "lasa", "--protocol", "fractions", "--methods", ",".join(BEFORE), *jobs],
                     tmp / "lasa-before")
        print(f"ratio: every method / before = {full / before:.2f}; {load()}")
        if not args.no_held_out:
            run("held-out (stand-in)", ["--protocol", "held-out", *jobs], tmp / "held-out")
        if args.paper:
            run("paper protocol (stand-in)", ["--protocol", "paper", *jobs], tmp / "paper")


if __name__ == "__main__":
    main()
