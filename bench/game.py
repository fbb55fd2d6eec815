"""Benchmark: a whole headless tic-tac-toe game, its wall time against its floor, peak memory, a long series.

Run from the checkout::

    python bench/game.py                 # 3 single games as separate processes, 3 times each, + 20 in one process
    python bench/game.py --series 50     # a longer series (texture leaks show as RSS growth)

Part 0, the floor, measured in the same run: what a game cannot cost less than with this robot,
simulator and renderer --

- start-up: a fresh process that imports hila and prepares the game (the program, the world, the
  iCub loaded into PyBullet, its calibrations read) and exits, timed from outside, as the game is;
- physics: the game's simulator steps (counted in one in-process game with the same seed and
  opponent) times the cost of a bare ``stepSimulation`` in that scene;
- eyes: the game's images (counted the same way) times the cost of one image as it is made
  there: a glance while drawing reads only the eye's fovea around the grid (a part of the
  sensor, :func:`hila_lang.robot.lens.sensor_window`), a look at the board and the output
  folder's eye.png are whole eye images through the lens, and the output folder's top.png is a
  480 x 480 view from above with the arm put aside (twice a whole eye image's cost: priced as
  one, it made the floor 0.06 s too low).

``floor = start-up + steps x step + glances x glance + images x image + tops x top`` per game;
``ratio = wall / floor`` (goal <= 1.5).  The unit costs are sampled before the single games,
after each round of them (two start-up processes, 5 x 1000 bare steps, 7 whole eye images, 7 of
the game's fovea glances -- each with its eye, its fovea and the arm where it was -- and 3 top
views each time, in the counted game's scene kept open), and their medians used: on a shared
machine the load moves within minutes, and unit costs timed at one moment put the same code's
ratio anywhere between 0.96 and 1.73 (main, load 10-14, two runs five minutes apart).  For the
same reason each seed's game is played ``--repeat`` times (3), in rounds over the seeds, and its
wall is their median: one game each put the same code's per-seed ratios between 1.43 and 1.60
in one run.

Part 1 times ``hila exec programs/game.hila`` as a fresh process (start-up, loading the iCub,
the whole game, the output folder), reading the child's peak resident memory.  Targets: under
20 s wall and under 1 GB peak (issue 5).  Part 2 plays games back to back in one process, each
with its own PyBullet client, and prints the resident memory after each, so a leak (PyBullet's
``loadTexture`` on every ink reload, docs/design.md §5) shows as growth per game.  The last line
sums it up::

    game wall=<s> floor=<s> ratio=<wall/floor> startup=<s> steps=<n>x<ms> glances=<n>x<ms> images=<n>x<ms> tops=<n>x<ms> peak=<MB> series=<n> failed=<games that ended in an error> rss_growth_per_game=<MB> r_min=<R>

Beside the floor it prints where the in-process game's time went: the stepping loop, the IK, the
rendering, the robot's looks at the board and its glances (each with the part spent taking eye
images; the rest is the robot's processing of them), writing the outputs.

Every single game is set against its own floor: the seeds' scenes differ, and so do their counts
(seeds 0-2: 6442, 7466 and 5800 steps; 105, 110 and 105 glances), so each seed is also played
once in process to count them (a floor counted on seed 0 alone made seed 1's game look 16 % of
its steps slower than it was).  ``wall`` and ``floor`` in the last line are the medians over the
seeds, ``ratio`` the median of the per-game ratios; ``steps``, ``glances`` and ``images`` are
seed 0's counts (the line above prints each seed's).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = ROOT / "programs" / "game.hila"


def rss_mb() -> float:
    """Current resident set size of this process, MB (Linux /proc)."""
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


#: ``python -m hila_lang ARGS`` that writes its own peak resident memory (VmHWM, kB) to a file as
#: it exits.  The child's rusage cannot say it: Linux keeps a process's largest RSS across exec,
#: and the child was forked from this process, which holds the counted games (448 MB read as a
#: game's peak when a game's own was 264-319 MB).
PEAK_CHILD = """
import runpy, sys
peak_file, sys.argv = sys.argv[1], ["hila", *sys.argv[2:]]
try:
    runpy.run_module("hila_lang", run_name="__main__", alter_sys=True)
finally:
    with open("/proc/self/status") as fh:
        peak = next(line.split()[1] for line in fh if line.startswith("VmHWM:"))
    with open(peak_file, "w") as fh:
        fh.write(peak)
"""


def one_process_game(seed: int, opponent: str, out: Path) -> tuple[float, float, dict]:
    """Wall time (s), the child's peak RSS (MB) and the report of one ``hila exec`` run."""
    args = [str(PROGRAM), "--seed", str(seed), "--opponent", opponent, "--out", str(out), "--quiet"]
    peak_file = out.parent / f"peak{seed}.txt"
    cmd = [sys.executable, "-c", PEAK_CHILD, str(peak_file), "exec", *args]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"game failed (exit {proc.returncode}):\n{proc.stderr}")
    peak = int(peak_file.read_text()) / 1e3  # kB -> MB
    return wall, peak, json.loads((out / "report.json").read_text())


STARTUP = """
import io, sys
from pathlib import Path
from hila_lang.plugins.options import RunOptions
from hila_lang.session.runner import prepare
interp = prepare(Path(sys.argv[1]), RunOptions(seed=0, out=Path(sys.argv[2]), settings={"opponent": "minimax"},
                 stdin=io.StringIO(), stdout=io.StringIO()), "pybullet")
interp.backend.close()
"""


def startup_s(out: Path, k: int) -> float:
    """Wall time (s) of a fresh process that imports hila, prepares the game and exits."""
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", STARTUP, str(PROGRAM), str(out / f"startup{k}")], cwd=ROOT, check=True,
                   capture_output=True)
    return time.perf_counter() - t0


def counted_game(seed: int, out: Path):
    """One in-process game (``hila exec``'s seed and opponent), left open for :class:`Probe`:
    the interpreter and its counts (simulator steps, eye images, IK, loop and render times, and
    the time spent in the robot's looks at the board and in its glances, each with the part of it
    that went into eye images: what is left is their processing, above the floor)."""
    from hila_lang.plugins.options import RunOptions
    from hila_lang.session.runner import prepare
    from hila_lang.worlds.tictactoe import player, tracking

    options = RunOptions(seed=seed, out=out, settings={"opponent": "minimax"}, stdin=io.StringIO(), stdout=io.StringIO())
    interp = prepare(PROGRAM, options, "pybullet")
    backend, glances = interp.backend, []
    eyes = backend.eyes
    camera_image = eyes.camera_image
    timed = {"look": [0, 0.0, 0.0], "glance": [0, 0.0, 0.0]}  # calls, seconds, of them in eye images
    inside = []  # the timed stage an eye image is taken for

    eye_images = [0]  # whole eye images (the rest of the renders that are not glances: top views)

    def counted(eye="left", **kw):  # a fovea glance (a region given) or a whole eye image
        if kw.get("region") is not None:  # where it looked and where the arm was: the probe's glances
            glances.append((eye, np.array(kw["region"]), backend.body.arm_angles()))
        else:
            eye_images[0] += 1
        a = time.perf_counter()
        try:
            return camera_image(eye, **kw)
        finally:
            if inside:
                timed[inside[-1]][2] += time.perf_counter() - a

    def timing(name, func):
        def run(*args, **kw):
            inside.append(name)
            a = time.perf_counter()
            try:
                return func(*args, **kw)
            finally:
                inside.pop()
                timed[name][0] += 1
                timed[name][1] += time.perf_counter() - a
        return run

    look_at_board, glance = player.look_at_board, tracking.SheetTracker.glance
    eyes.camera_image = counted
    player.look_at_board = timing("look", look_at_board)
    tracking.SheetTracker.glance = timing("glance", glance)
    try:
        t0 = time.perf_counter()
        interp.run()
        in_game = time.perf_counter() - t0
    finally:
        eyes.camera_image = camera_image
        player.look_at_board, tracking.SheetTracker.glance = look_at_board, glance
    stats = interp.backend.stats
    return interp, {"steps": stats["steps"], "glances": len(glances), "images": stats["renders"] - len(glances),
                    "eye_images": eye_images[0],
                    "glance_views": glances,
                    "in_game_s": in_game,
                    "ik_solves": stats["ik_solves"], "ik_s": stats["ik_seconds"], "step_loop_s": stats["step_seconds"],
                    "render_s": stats["render_seconds"], "timed": timed}


def finish_counted(interp, counts: dict) -> tuple[int, int, int, int]:
    """Write the counted game's output folder (its pictures: an eye image, eye.png, and a top
    view, top.png; the back end is closed), adding them and the time it took to ``counts``;
    returns (simulator steps, fovea glances, whole eye images, top views)."""
    from hila_lang.session.runner import finish

    eyes = interp.backend.eyes
    camera_image, before = eyes.camera_image, interp.backend.stats["renders"]

    def counted(*args, **kw):
        counts["eye_images"] += 1
        return camera_image(*args, **kw)

    eyes.camera_image = counted
    a = time.perf_counter()
    try:
        finish(interp)
    finally:
        eyes.camera_image = camera_image
    counts["outputs_s"] = time.perf_counter() - a
    counts["images"] += interp.backend.stats["renders"] - before
    return counts["steps"], counts["glances"], counts["eye_images"], counts["images"] - counts["eye_images"]


def seed_counts(seed: int, out: Path) -> tuple[int, int, int, int]:
    """(simulator steps, fovea glances, whole eye images, top views) of game ``seed``, the
    output folder's pictures included."""
    return finish_counted(*counted_game(seed, out))


class Probe:
    """The floor's unit costs, sampled again and again in the counted game's scene: a start-up
    process, a bare ``stepSimulation`` (5 x 1000, the arm held), a whole eye image (7, the eyes
    in turn) and a fovea glance (7 of the game's glances spread over it, each with its eye, its
    fovea and the arm where it was: the arm in view costs the renderer); :meth:`costs` gives the
    medians of every sample."""

    def __init__(self, interp, out: Path, glances: list) -> None:
        self.backend, self.out = interp.backend, out
        self.views = [glances[int(k)] for k in np.linspace(0, len(glances) - 1, 7)] if glances else []
        self.start, self.step, self.image, self.glance, self.top = [], [], [], [], []

    def sample(self) -> None:
        be = self.backend
        for _ in range(2):  # two: its median moved most between runs (0.96-1.14 s) of the unit costs
            self.start.append(startup_s(self.out, len(self.start)))
        pb, c = be.sim.pb, be.sim.client
        for _ in range(5):  # a busy machine slows them as it slows a game
            a = time.perf_counter()
            for _ in range(1000):
                pb.stepSimulation(physicsClientId=c)
            self.step.append((time.perf_counter() - a) / 1000)
        renders = be.stats["renders"]
        for k in range(7):
            a = time.perf_counter()
            be.eyes.camera_image(("left", "right")[k % 2])
            self.image.append(time.perf_counter() - a)
        saved = pb.saveState(physicsClientId=c)  # the arm where it was at each glance, then back
        try:
            for eye, region, arm in self.views:
                for index, value in zip(be.body.arm_joints, arm):
                    pb.resetJointState(be.body.id, index, float(value), 0.0, physicsClientId=c)
                a = time.perf_counter()
                be.eyes.camera_image(eye, region=region)
                self.glance.append(time.perf_counter() - a)
        finally:
            pb.restoreState(stateId=saved, physicsClientId=c)
            pb.removeState(saved, physicsClientId=c)
        for _ in range(3):  # the report's top view, as it is made (the arm aside, 480 x 480)
            a = time.perf_counter()
            be.overview.top_view_image(arm_aside=True)
            self.top.append(time.perf_counter() - a)
        be.stats["renders"] = renders  # the probe's images are not the game's

    def costs(self) -> tuple[float, float, float, float, float]:
        return tuple(float(np.median(v)) if v else 0.0
                     for v in (self.start, self.step, self.glance, self.image, self.top))


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
    parser.add_argument("--repeat", type=int, default=3,
                        help="times each single-process game is played, in rounds over the seeds; its wall is "
                             "their median (default 3)")
    args = parser.parse_args(argv)
    for name in ("games", "repeat"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} must be at least 1, got {getattr(args, name)}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print(f"load average {os.getloadavg()[0]:.2f} at start ({os.cpu_count()} cores, shared)", flush=True)
        interp, counts = counted_game(0, tmp / "counted")
        probe = Probe(interp, tmp, counts.pop("glance_views"))
        # every game against its own floor: the seeds' scenes differ, and so do their counts
        # (seeds 0-2: 6442, 7466, 5800 steps; 105, 110, 105 glances)
        tallies = {seed: seed_counts(seed, tmp / f"counted{seed}") for seed in range(1, args.games)}
        probe.sample()
        runs: dict[int, list[float]] = {seed: [] for seed in range(args.games)}
        r_all: list[float] = []
        peak = 0.0
        for round_ in range(args.repeat):  # rounds over the seeds: a slow minute slows every seed alike
            for seed in range(args.games):
                wall, game_peak, report = one_process_game(seed, "minimax", tmp / f"g{seed}")
                peak = max(peak, game_peak)
                runs[seed].append(wall)
                r_all += [m["r"] for m in report["marks"] if m["r"] is not None]
                print(f"game seed={seed} run {round_ + 1}: wall {wall:.2f} s, result {report['result']}, "
                      f"{len(report['moves'])} moves, in-game {report['wall_time_s']:.2f} s, "
                      f"tracking median {report['tracking_error_mm']['median']:.3f} mm "
                      f"max {report['tracking_error_mm']['max']:.3f} mm, "
                      f"R min {min(m['r'] for m in report['marks']):.4f}", flush=True)
            probe.sample()
        walls = [float(np.median(runs[seed])) for seed in range(args.games)]
        tallies[0] = finish_counted(interp, counts)
        start, step, glance, image, top = probe.costs()
        counts.update(step_s=step, glance_s=glance, image_s=image, top_s=top)
        floors = {seed: start + n * step + g * glance + i * image + t * top for seed, (n, g, i, t) in tallies.items()}
        floor = floors[0]
        print(f"floor: start-up {start:.2f} s + {counts['steps']} steps x {step * 1e3:.3f} ms "
              f"+ {counts['glances']} fovea glances x {glance * 1e3:.1f} ms "
              f"+ {tallies[0][2]} whole eye images x {image * 1e3:.1f} ms + {tallies[0][3]} top views x "
              f"{top * 1e3:.1f} ms = {floor:.2f} s (medians of "
              f"{len(probe.start)} samples, before, between and after the games); the in-process game spent "
              f"{counts['in_game_s']:.2f} s: stepping loop {counts['step_loop_s']:.2f} s, "
              f"IK {counts['ik_solves']} solves {counts['ik_s']:.2f} s, rendering {counts['render_s']:.2f} s, "
              + ", ".join(f"{n} {what} {s:.2f} s of which eye images {i:.2f} s"
                          for what, (n, s, i) in (("looks at the board", counts["timed"]["look"]),
                                                  ("glances", counts["timed"]["glance"])))
              + f"; writing the outputs {counts['outputs_s']:.2f} s", flush=True)
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
        ratios = [w / floors[seed] for seed, w in enumerate(walls)]
        for seed, w in enumerate(walls):
            n, g, i, t = tallies[seed]
            print(f"game seed={seed}: wall {w:.2f} s (median of {', '.join(f'{x:.2f}' for x in runs[seed])}) against "
                  f"its floor {floors[seed]:.2f} s ({n} steps, {g} glances, {i} whole eye images, {t} top views): "
                  f"{ratios[seed]:.2f}")
        wall = float(np.median(walls))
        print(f"load average {os.getloadavg()[0]:.2f} at the end")
        print(f"game wall={wall:.2f} floor={float(np.median(list(floors.values()))):.2f} ratio={float(np.median(ratios)):.2f} "
              f"startup={start:.2f} "
              f"steps={counts['steps']}x{counts['step_s'] * 1e3:.3f}ms glances={counts['glances']}x"
              f"{counts['glance_s'] * 1e3:.1f}ms images={tallies[0][2]}x"
              f"{counts['image_s'] * 1e3:.1f}ms tops={tallies[0][3]}x{counts['top_s'] * 1e3:.1f}ms peak={peak:.0f} series={args.series} failed={failed} "
              f"rss_growth_per_game={growth:.2f} r_min={min(r_all):.4f}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
