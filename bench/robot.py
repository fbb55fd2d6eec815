"""Benchmark: the PyBullet iCub draws a 6 cm circle (diameter) in each of the nine game cells.

Reports, headless on this machine:

- tracking error: every simulation step of the pen-down strokes, the pen tip against the point
  of the planned path the controller was aiming at then (time-aligned, so lag counts), mm;
- path deviation: every pen-down sample against the nearest point of the planned polyline, mm;
- IK wall time per waypoint (waypoints at most 2 mm apart), ms;
- simulation speed against real time: simulated seconds / wall seconds of the control loop
  (stepping, control, recording) -- and, for information, of whole moves including IK and
  against the process's CPU time (other jobs on a shared machine slow the wall clock);
- image render time: eye camera (320x240) and top view (480x480), ms;
- the URDF load (backend construction) time.

The last line is ``tracking median=<mm> max=<mm> realtime=<factor>x`` (targets: median <= 1 mm,
max <= 3 mm, >= 10x real time).  Not a test.

    python bench/robot.py [--points 120] [--renders 10]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from hila_lang.robot.backend import PyBulletBackend
from hila_lang.worlds.tictactoe.board import Grid, cell_center


def circle(scene: Grid, cell: int, radius: float, n: int) -> np.ndarray:
    right, far = scene.axes()
    angle = np.linspace(0.0, 2.0 * np.pi, n + 1)
    return cell_center(scene, cell) + radius * (np.cos(angle)[:, None] * right + np.sin(angle)[:, None] * far)


def polyline_distance(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """Distance (N,) from each point (N, 3) to the nearest point of a polyline (M, 3)."""
    a, b = polyline[:-1], polyline[1:]
    ab = b - a
    t = np.einsum("nmk,mk->nm", points[:, None, :] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-18)
    nearest = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - nearest, axis=2).min(axis=1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=120, help="waypoints per planned circle")
    ap.add_argument("--renders", type=int, default=10, help="images timed per camera")
    args = ap.parse_args()

    clock = time.perf_counter()
    board = Grid.game()
    robot = PyBulletBackend(board.paper(), arm="ready")
    load = time.perf_counter() - clock
    lift = np.array([0.0, 0.0, 0.02])
    tracking, deviation = [], []
    draw_wall = draw_sim = draw_cpu = 0.0
    with robot:
        for cell in range(1, 10):
            planned = circle(board, cell, 0.03, args.points)
            robot.move(np.array([robot.hand_position() + lift, planned[0] + lift, planned[0]]), label=f"reach {cell}")
            clock, cpu = time.perf_counter(), time.process_time()
            robot.move(planned, pen_down=True, label=f"circle {cell}")
            draw_wall += time.perf_counter() - clock
            draw_cpu += time.process_time() - cpu
            trace = robot.traces[-1]
            draw_sim += len(trace.executed) / 240.0
            tracking.append(np.linalg.norm(trace.executed - trace.reference, axis=1))
            deviation.append(polyline_distance(trace.executed, planned))
            err = tracking[-1] * 1e3
            print(f"cell {cell}: {len(trace.executed)} steps ({len(trace.executed) / 240:.2f} s), "
                  f"tracking median {np.median(err):.4f} mm max {err.max():.4f} mm, inked {trace.inked}")
        stats = dict(robot.stats)
        robot.stats["renders"] = robot.stats["render_seconds"] = 0
        for _ in range(args.renders):
            robot.eyes.camera_image("left")
        eye_ms = robot.stats["render_seconds"] / args.renders * 1e3
        robot.stats["renders"] = robot.stats["render_seconds"] = 0
        for _ in range(args.renders):
            robot.overview.top_view_image(480)
        top_ms = robot.stats["render_seconds"] / args.renders * 1e3

    tracking_mm = np.concatenate(tracking) * 1e3
    deviation_mm = np.concatenate(deviation) * 1e3
    realtime = stats["steps"] / 240.0 / stats["step_seconds"]
    print(f"backend construction (URDF load, scene, ready posture): {load:.2f} s")
    print(f"tracking error (time-aligned): median {np.median(tracking_mm):.4f} mm, max {tracking_mm.max():.4f} mm "
          f"over {len(tracking_mm)} steps")
    print(f"path deviation (to the planned polyline): median {np.median(deviation_mm):.4f} mm, "
          f"max {deviation_mm.max():.4f} mm")
    print(f"IK: {stats['ik_solves']} waypoints, {stats['ik_seconds'] / stats['ik_solves'] * 1e3:.3f} ms per waypoint")
    print(f"simulation: {stats['steps']} steps, {realtime:.1f}x real time in the control loop; "
          f"whole circles including IK {draw_sim / draw_wall:.1f}x (CPU time: {draw_sim / draw_cpu:.1f}x)")
    print(f"render: eye camera 320x240 {eye_ms:.1f} ms, top view 480x480 {top_ms:.1f} ms")
    print(f"tracking median={np.median(tracking_mm):.4f} max={tracking_mm.max():.4f} realtime={realtime:.1f}x")


if __name__ == "__main__":
    main()
