"""Pictures of each robot at the end of a game of tic-tac-toe, for docs/robots.md.

For every robot, plays ``programs/game.hila --opponent random --seed S`` headless (as ``hila
exec`` does), then renders the scene from the front right (the arm, the table, the sheet, and
for an arm without a head its stereo rig on the stand) beside what the robot's own left eye saw
last, and writes ``OUT/robot-NAME.png`` (960x360).

    python bench/robot_pictures.py --out docs/images [--robots icub panda kuka] [--seed 0]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def picture(robot: str, seed: int) -> np.ndarray:
    import cv2

    from hila_lang.core.fileio import write_png  # noqa: F401 - the caller writes
    from hila_lang.plugins.options import RunOptions
    from hila_lang.session.runner import prepare
    from hila_lang.sim.camera import Camera, intrinsics, look_at

    import io

    options = RunOptions(seed=seed, settings={"robot": robot, "opponent": "random", "report": "no"},
                         stdout=io.StringIO())
    interp = prepare("programs/game.hila", options, "pybullet")
    try:
        interp.run()
        backend = interp.backend
        base = np.asarray(backend.robot.base_position, dtype=float)
        target = np.array([0.5 * (base[0] + 0.31), -0.09, 0.72])
        camera = Camera(intrinsics(480, 360, 55.0), look_at(target + [0.95, -0.95, 0.55], target), 480, 360)
        scene = backend.sim.render(camera)
        eye = backend.eyes.camera_image("left").rgb
        eye = cv2.resize(eye, (480, 360), interpolation=cv2.INTER_LINEAR)
        return np.hstack([scene, eye])
    finally:
        interp.backend.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--robots", nargs="+", default=["icub", "panda", "kuka"])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    from hila_lang.core.fileio import write_png

    for robot in args.robots:
        path = args.out / f"robot-{Path(robot).stem}.png"
        write_png(path, picture(robot, args.seed))
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
