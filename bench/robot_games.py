"""Tic-tac-toe on each robot over seeds: the table of issue 33's "Done when".

Runs ``hila exec programs/game.hila --robot R --out OUT/R-S --opponent random --seed S`` for every
robot and seed (one process each, as a user runs it), reads each ``report.json`` and prints per
game: the result, misread cells, marks outside their cell, looks, the robot's wall time; then
per robot the wins, draws, losses and unfinished games.  Exit status 1 when a game was lost or
failed, or had a misread or a mark outside its cell.

    python bench/robot_games.py --robots panda kuka --seeds 0-9 --out /tmp/games
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path


def _seeds(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["panda", "kuka"], help="robot names or paths")
    parser.add_argument("--seeds", type=_seeds, default=_seeds("0-9"), help="e.g. 0-9 or 0,3,5")
    parser.add_argument("--out", type=Path, required=True, help="folder for the games' output folders")
    parser.add_argument("--hila", default=str(Path(sys.executable).with_name("hila")), help="the hila program")
    args = parser.parse_args(argv)
    rows, bad = [], 0
    print(f"{'robot':>8} {'seed':>4} {'result':>10} {'misreads':>8} {'outside':>7} {'looks':>5} {'wall s':>7} {'exit':>4}",
          flush=True)
    for robot in args.robots:
        for seed in args.seeds:
            out = args.out / f"{Path(robot).stem}-{seed}"
            clock = time.perf_counter()
            proc = subprocess.run([args.hila, "exec", "programs/game.hila", "--robot", robot, "--out", str(out),
                                   "--opponent", "random", "--seed", str(seed)], capture_output=True, text=True)
            wall = time.perf_counter() - clock
            try:
                report = json.loads((out / "report.json").read_text())
            except (OSError, ValueError):
                report = {}
            vision = report.get("vision") or {}
            row = {"robot": robot, "seed": seed, "result": report.get("result") or "failed",
                   "misreads": vision.get("misreads"), "outside": report.get("marks_outside_cell"),
                   "looks": vision.get("looks"), "wall": wall, "exit": proc.returncode}
            if isinstance(row["misreads"], list):
                row["misreads"] = len(row["misreads"])
            rows.append(row)
            ok = row["result"] in ("robot", "draw") and row["misreads"] == 0 and row["outside"] == 0 and proc.returncode == 0
            bad += not ok
            print(f"{Path(robot).stem:>8} {seed:>4} {row['result']:>10} {str(row['misreads']):>8} {str(row['outside']):>7} "
                  f"{str(row['looks']):>5} {wall:7.1f} {proc.returncode:>4}" + ("" if ok else "  <--"), flush=True)
            if proc.returncode not in (0,):
                print("    " + (proc.stderr.strip().splitlines() or [""])[-1][:300], flush=True)
    print()
    for robot in args.robots:
        mine = [r for r in rows if r["robot"] == robot]
        count = {k: sum(r["result"] == k for r in mine) for k in ("robot", "draw", "opponent")}
        print(f"{Path(robot).stem}: {count['robot']} won, {count['draw']} drawn, {count['opponent']} lost, "
              f"{len(mine) - sum(count.values())} unfinished of {len(mine)}; misreads "
              f"{sum(r['misreads'] or 0 for r in mine)}, marks outside their cell {sum(r['outside'] or 0 for r in mine)}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
