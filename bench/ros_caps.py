"""Benchmark: how fast the joints of each arm turn on the shipped programs when the ROS back end
times a move at the pen's speed, and what the joint caps of ``hila_lang/robot/kinematic_arm.py``
do to them (no ROS needed: planning only).

For every robot and program, the program runs on the dry back end with ``--robot`` (the paths as
the engine asks for them, each from where the last ended); every move is then planned for that
robot (:func:`hila_lang.ros.plan.plan_move`) from the joints where the previous plan ended
(the first from the IK of the hand's start from the robot's seed), once with no joint caps and
once with the robot's caps.  Printed per robot and program: the number of moves, the fastest
joint (rad/s) and the largest joint acceleration (rad/s^2) with no caps, the joint's URDF velocity
and cap, and how many moves the caps stretch and by how much at most.

    python bench/ros_caps.py [--robots icub panda kuka] [--programs programs/reach_return.hila programs/game.hila]
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import os
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def program_moves(program: str, robot: str) -> tuple[np.ndarray, list]:
    """The hand's start (3,) and the moves (path (T, 3), pen_down, label) the program asks of ``robot``
    on the dry back end."""
    from hila_lang.plugins.options import RunOptions
    from hila_lang.session.runner import finish, prepare

    with tempfile.TemporaryDirectory() as out:  # the game's report and pictures: not kept
        options = RunOptions(seed=0, stdout=io.StringIO(), settings={"robot": robot}, out=Path(out) / "run")
        interp = prepare(program, options, "dry")
        backend = interp.backend
        moves = []
        original = backend.move

        def move(path, *, pen_down=False, label=""):
            moves.append((np.array(path, dtype=float), pen_down, label))
            return original(path, pen_down=pen_down, label=label)

        backend.move = move
        start = backend.hand_position()
        interp.run()
        finish(interp)
    return start, moves


def joint_rates(plan) -> tuple[float, float, int]:
    """The fastest joint speed (rad/s), the largest joint acceleration (rad/s^2) at the knots, and the joint."""
    if len(plan.times) < 2:
        return 0.0, 0.0, 0
    acc = np.gradient(plan.velocities, plan.times, axis=0)
    return float(np.abs(plan.velocities).max()), float(np.abs(acc).max()), int(np.argmax(np.abs(acc).max(axis=0)))


def measure(robot: str, program: str) -> dict:
    from hila_lang.robot.kinematic_arm import from_spec
    from hila_lang.robot.spec import resolve
    from hila_lang.ros.plan import plan_move

    arm = from_spec(resolve(robot))
    free = dataclasses.replace(arm, velocity=np.full(arm.dof, np.inf), acceleration=np.full(arm.dof, np.inf))
    start, moves = program_moves(program, robot)
    q = arm.posture_at(start)
    if q is None:
        raise SystemExit(f"{robot}: the hand's start {start} has no IK solution")
    speed, accel, stretched, most = 0.0, 0.0, 0, 1.0
    for path, pen_down, label in moves:
        plan = plan_move(free, q, path, pen_down=pen_down, gap=np.inf, label=label)
        v, a, _ = joint_rates(plan)
        speed, accel = max(speed, v), max(accel, a)
        capped = plan_move(arm, q, path, pen_down=pen_down, gap=np.inf, label=label)
        ratio = capped.duration / plan.duration if plan.duration > 0 else 1.0
        if ratio > 1.0 + 1e-6:
            stretched += 1
            most = max(most, ratio)
        q = plan.positions[-1]
    return {"moves": len(moves), "speed": speed, "accel": accel, "stretched": stretched, "most": most,
            "velocity": arm.velocity, "acceleration": arm.acceleration, "urdf": arm.spec.limits()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["icub", "panda", "kuka"])
    ap.add_argument("--programs", nargs="+", default=["programs/reach_return.hila", "programs/game.hila"])
    args = ap.parse_args()
    os.chdir(ROOT)
    print(f"load average {os.getloadavg()[0]:.2f} (1 min), 2 cores")
    print(f"{'robot':7}{'program':28}{'moves':>6}{'fastest rad/s':>15}{'max acc rad/s2':>16}"
          f"{'URDF vel rad/s':>17}{'caps':>15}{'stretched':>11}{'at most':>9}")
    for robot in args.robots:
        for program in args.programs:
            m = measure(robot, program)
            urdf = sorted({round(v["velocity"], 3) for v in m["urdf"].values()})
            caps = f"{np.min(m['velocity']):g}-{np.max(m['velocity']):g}/{np.max(m['acceleration']):g}"
            print(f"{robot:7}{Path(program).name:28}{m['moves']:6d}{m['speed']:15.2f}{m['accel']:16.1f}"
                  f"{'/'.join(f'{v:g}' for v in urdf):>17}{caps:>15}{m['stretched']:11d}{m['most']:9.2f}")


if __name__ == "__main__":
    main()
