"""Benchmark: the two headline evaluations of ``hila eval``, timed as a user runs them.

1. ``hila eval --protocol held-out --jobs 2``: the stand-in, 75 x 75 pairs, N = 1, OSILA and the
   five controls (33,750 generations plus every metric);
2. ``hila eval --dataset lasa --jobs 2``: the 14 LASA development shapes, 588 pairs of different
   demonstrations, N = 1..4, OSILA and the five controls (14,112 generations plus metrics).

Each runs as a fresh command (a new process, so joblib's workers start and load the compiled
kernels as they would for a user) and must finish in <= 90 s on the 2-core project machine; the
wall time is printed.  ``--paper`` also times ``--protocol paper`` (N = 1..4, four times the
held-out work, same target).  Not a test.

    python bench/eval.py [--jobs 2] [--paper]
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


def run(label: str, argv: list[str], out: Path) -> None:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "eval", *argv, "--out", str(out), "--no-progress"],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        print(f"{label}: failed (exit {proc.returncode})\n{proc.stderr}")
        return
    doc = json.loads((out / "results.json").read_text())
    rows = {(r["method"], r["n"]): r for r in doc["summary"]}
    grid = doc["run"]["wall_seconds"]
    print(f"{label}: {wall:.1f} s wall for the command, {grid:.1f} s in the grid "
          f"({'within' if wall <= TARGET_S else 'OVER'} the {TARGET_S:.0f} s target); "
          f"{doc['run']['pairs']} pairs x N = {doc['run']['segments']} x {len(doc['run']['methods'])} methods")
    for n in doc["run"]["segments"]:
        o = rows[("osila", n)]
        print(f"  N = {n}: OSILA mean MSD {o['msd']:.4g}, Frechet {o['frechet']:.4g}, "
              f"{o['ms_per_path']:.2f} ms per path")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2, help="joblib processes (default 2, the machine's cores)")
    ap.add_argument("--paper", action="store_true", help="also time --protocol paper")
    args = ap.parse_args()
    print(f"machine: {os.cpu_count()} cores (shared); jobs = {args.jobs}")
    jobs = ["--jobs", str(args.jobs)]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        run("held-out (stand-in)", ["--protocol", "held-out", *jobs], tmp / "held-out")
        run("LASA (development shapes)", ["--dataset", "lasa", *jobs], tmp / "lasa")
        if args.paper:
            run("paper protocol (stand-in)", ["--protocol", "paper", *jobs], tmp / "paper")


if __name__ == "__main__":
    main()
