"""Benchmark: a whole headless tic-tac-toe game, its wall time and peak memory, and a long series.

Run from the checkout::

    python bench/game.py                 # 3 single games as separate processes + 20 in one process
    python bench/game.py --series 50     # a longer series (texture leaks show as RSS growth)

Part 1 times ``hila exec programs/game.hila`` as a fresh process (start-up, loading the iCub,
the whole game, the output folder), reading the child's peak resident memory.  Targets: under
20 s wall and under 1 GB peak (issue 5).  Part 2 plays games back to back in one process, each
with its own PyBullet client, and prints the resident memory after each, so a leak (PyBullet's
``loadTexture`` on every ink reload, docs/design.md §5) shows as growth per game.  The last line
sums it up::

    game wall=<s> peak=<MB> series=<n> failed=<games that ended in an error> rss_growth_per_game=<MB> r_min=<R>
"""

from __future__ import annotations

import argparse
import io
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = ROOT / "programs" / "game.hila"


def rss_mb() -> float:
    """Current resident set size of this process, MB (Linux /proc)."""
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def one_process_game(seed: int, opponent: str, out: Path) -> tuple[float, float, dict]:
    """Wall time (s), the child's peak RSS (MB) and the report of one ``hila exec`` run."""
    args = [str(PROGRAM), "--seed", str(seed), "--opponent", opponent, "--out", str(out), "--quiet"]
    cmd = [sys.executable, "-m", "hila_lang", "exec", *args]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"game failed (exit {proc.returncode}):\n{proc.stderr}")
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1e3  # KB -> MB (max over children)
    return wall, peak, json.loads((out / "report.json").read_text())


def series(n: int, out: Path) -> list[tuple[float, float, dict | str]]:
    """``n`` games in this process: (wall s, RSS MB after the game, report -- or the error's
    first line for a game that failed: a finding, and the series goes on) per game."""
    from hila_lang.core.errors import HilaError
    from hila_lang.plugins.options import RunOptions
    from hila_lang.session.runner import finish, prepare

    rows = []
    for k in range(n):
        options = RunOptions(seed=k, out=out / f"s{k}", settings={"opponent": ("random", "minimax")[k % 2]},
                             stdin=io.StringIO(), stdout=io.StringIO())
        t0 = time.perf_counter()
        interp = prepare(PROGRAM, options, "pybullet")
        try:
            interp.run()
            report: dict | str = finish(interp)
        except HilaError as exc:
            report = str(exc).splitlines()[0]
        rows.append((time.perf_counter() - t0, rss_mb(), report))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--games", type=int, default=3, help="single-process games to time (default 3)")
    parser.add_argument("--series", type=int, default=20, help="games in one process (default 20)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        walls, r_all = [], []
        peak = 0.0
        for seed in range(args.games):
            wall, peak, report = one_process_game(seed, "minimax", tmp / f"g{seed}")
            walls.append(wall)
            r_all += [m["r"] for m in report["marks"] if m["r"] is not None]
            print(f"game seed={seed}: wall {wall:.2f} s, result {report['result']}, "
                  f"{len(report['moves'])} moves, in-game {report['wall_time_s']:.2f} s, "
                  f"tracking median {report['tracking_error_mm']['median']:.3f} mm "
                  f"max {report['tracking_error_mm']['max']:.3f} mm, "
                  f"R min {min(m['r'] for m in report['marks']):.4f}", flush=True)
        print(f"peak RSS of a game process: {peak:.0f} MB", flush=True)
        growth = float("nan")
        failed = 0
        if args.series > 0:
            rows = series(args.series, tmp)
            for k, (wall, rss, report) in enumerate(rows):
                if isinstance(report, str):
                    failed += 1
                    print(f"series game {k + 1:3d}: {wall:5.2f} s, RSS {rss:7.1f} MB, FAILED: {report}", flush=True)
                    continue
                r_all += [m["r"] for m in report["marks"] if m["r"] is not None]
                print(f"series game {k + 1:3d}: {wall:5.2f} s, RSS {rss:7.1f} MB, {report['result']}", flush=True)
            if len(rows) >= 3:  # growth after the first game (which loads everything)
                growth = (rows[-1][1] - rows[1][1]) / (len(rows) - 2)
        print(f"game wall={max(walls):.2f} peak={peak:.0f} series={args.series} failed={failed} "
              f"rss_growth_per_game={growth:.2f} r_min={min(r_all):.4f}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
