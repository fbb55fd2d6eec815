"""Benchmark: every robot beside the iCub, in the same run -- IK, tracking, speed, a whole game.

Per robot (``--robots``, default ``icub panda kuka``; a name, a spec file or a URDF), headless:

- IK wall time per waypoint (ms): the arm draws a 6 cm circle in each of the nine cells of the
  game's board, pen down, 120 waypoints a circle, densified to <= 2 mm (:mod:`hila_lang.robot.arm`);
- tracking error median / max (mm): every simulation step of those strokes, the pen tip against
  the point of the path the controller aimed at then (as ``bench/robot.py`` measures the iCub);
- real-time factor: simulated seconds / wall seconds of the 240 Hz control loop;
- the headless game's wall time (s): ``hila exec programs/game.hila --robot R --opponent random
  --seed 0`` as a separate process, as a user runs it, with its result.

Each figure is printed beside the iCub's, measured in the same run, with the ratio; a shared
machine's load moves the wall times of all robots alike (say ``uptime`` with the figures).
Not a test.

    python bench/robots.py [--robots icub panda kuka] [--no-game]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from hila_lang.robot.backend import PyBulletBackend
from hila_lang.robot.spec import resolve
from hila_lang.worlds.tictactoe.board import Grid, cell_center

ROOT = Path(__file__).resolve().parent.parent


def circle(grid: Grid, cell: int, radius: float, n: int) -> np.ndarray:
    right, far = grid.axes()
    angle = np.linspace(0.0, 2.0 * np.pi, n + 1)
    return cell_center(grid, cell) + radius * (np.cos(angle)[:, None] * right + np.sin(angle)[:, None] * far)


def arm_figures(name: str, points: int = 120) -> dict:
    """IK ms per waypoint, tracking median / max mm and the real-time factor of the nine circles."""
    grid = Grid.game()
    with PyBulletBackend(grid.paper(), arm="ready", robot=resolve(name)) as robot:
        lift = np.array([0.0, 0.0, 0.02])
        tracking = []
        for cell in range(1, 10):
            path = circle(grid, cell, 0.03, points)
            robot.move(np.vstack([path[0] + lift, path[0]]), label="reach")
            before = len(robot.traces)
            ik_solves, ik_seconds = robot.stats["ik_solves"], robot.stats["ik_seconds"]
            steps, step_seconds = robot.stats["steps"], robot.stats["step_seconds"]
            robot.move(path, pen_down=True, label="draw")
            trace = robot.traces[before]
            tracking.append(np.linalg.norm(trace.executed - trace.reference, axis=1))
            robot.move((path[-1] + lift)[None], label="lift")
        stats = robot.stats
        errors = np.concatenate(tracking) * 1000
        return {"ik_ms": 1000 * stats["ik_seconds"] / max(stats["ik_solves"], 1),
                "track_median": float(np.median(errors)), "track_max": float(errors.max()),
                "realtime": stats["steps"] / 240.0 / max(stats["step_seconds"], 1e-9)}


def game_figures(name: str) -> dict:
    hila = str(Path(sys.executable).with_name("hila"))
    clock = time.perf_counter()
    proc = subprocess.run([hila, "exec", "programs/game.hila", "--robot", name, "--opponent", "random", "--seed", "0"],
                          capture_output=True, text=True, cwd=ROOT)
    result = next((line for line in proc.stdout.splitlines() if line.startswith("result:")), f"exit {proc.returncode}")
    return {"game_s": time.perf_counter() - clock, "result": result.replace("result: ", "").split(";")[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["icub", "panda", "kuka"])
    parser.add_argument("--no-game", action="store_true", help="skip the headless games")
    args = parser.parse_args()
    robots = ["icub"] + [r for r in args.robots if r != "icub"]
    rows = {}
    for name in robots:
        rows[name] = arm_figures(name)
        if not args.no_game:
            rows[name].update(game_figures(name))
        print(f"measured {name}", file=sys.stderr, flush=True)
    ref = rows["icub"]
    columns = [("ik_ms", "IK ms/waypoint", "{:.3f}"), ("track_median", "tracking median mm", "{:.3f}"),
               ("track_max", "tracking max mm", "{:.3f}"), ("realtime", "real-time factor", "{:.1f}x")]
    if not args.no_game:
        columns.append(("game_s", "game wall s", "{:.1f}"))
    print(f"{'robot':<8}" + "".join(f"{title:>26}" for _, title, _ in columns) + ("   game result" if not args.no_game else ""))
    for name, row in rows.items():
        cells = []
        for key, _, fmt in columns:
            ratio = "" if name == "icub" else f" ({row[key] / ref[key]:.2f}x iCub)" if ref[key] else ""
            cells.append(f"{fmt.format(row[key]) + ratio:>26}")
        print(f"{Path(name).stem:<8}" + "".join(cells) + (f"   {row['result']}" if not args.no_game else ""))


if __name__ == "__main__":
    main()
