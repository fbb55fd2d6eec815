"""``hila snapshot --out DIR``: two PNGs of the simulated iCub drawing on the game board.

The robot starts with its arm parked at a random point above the board (``--seed``), the
opponent's hand-drawn cross (:func:`hila_lang.worlds.tictactoe.marks.cross_strokes`, same seed) is inked in
one cell, and the robot draws a circle in ``--cell``.  Half-way round the circle the eye camera
takes ``eye_<EYE>.png`` (320x240, the robot drawing); after the pen is lifted a camera above the
board takes ``board_top.png`` (the board, cell 1 top-left).
"""

from __future__ import annotations

import argparse

from ..core.argtypes import output_path, seed
from ..core.errors import InputError
from ..core.fileio import OutputFolder, write_png

HELP = "render the simulated iCub drawing: an eye-camera PNG and a top-down board PNG"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=output_path, required=True, metavar="DIR", help="folder to write the PNGs into")
    parser.add_argument("--cell", type=int, default=5, metavar="N", help="cell 1..9 the robot circles (default 5)")
    parser.add_argument("--opponent-cell", type=int, default=1, metavar="N", help="cell 1..9 with the opponent's cross (default 1; 0 for none)")
    parser.add_argument("--eye", choices=("left", "right"), default="left", help="eye camera (default left)")
    parser.add_argument("--seed", type=seed, default=0, help="seed of the arm's random start and the cross (default 0)")
    parser.add_argument("--size", type=int, default=480, metavar="PX", help="side of the top-down image (default 480)")
    parser.add_argument("--gui", action="store_true", help="show PyBullet's window (needs a display)")


def circle_path(scene, cell: int, radius: float, n: int = 120):
    """A closed circle (n + 1, 3) in ``cell`` on the paper, starting on the cell's right side."""
    # lazy: loads numpy, which importing this module does not
    import numpy as np

    from ..worlds.tictactoe.board import cell_center

    center = cell_center(scene, cell)
    right, far = scene.axes()
    angle = np.linspace(0.0, 2.0 * np.pi, n + 1)
    return center + radius * (np.cos(angle)[:, None] * right + np.sin(angle)[:, None] * far)


def run(args: argparse.Namespace) -> int:

    # lazy: loads numpy, which importing this module does not
    import numpy as np

    from ..worlds.tictactoe.marks import cross_strokes
    from ..robot.backend import PyBulletBackend
    from ..worlds.tictactoe.board import Grid, cell_center

    out = OutputFolder(args.out, "snapshot").path  # made and proved writable before the scene is built
    if not 1 <= args.cell <= 9 or not 0 <= args.opponent_cell <= 9 or args.cell == args.opponent_cell:
        raise InputError(
            f"--cell must be 1..9 and --opponent-cell 0..9 (0: none), different, got {args.cell} and {args.opponent_cell}"
        )
    if not 64 <= args.size <= 2048:
        raise InputError(f"--size must be 64..2048 pixels, got {args.size}")
    scene = Grid.game()
    cell = scene.grid_size / 3
    with PyBulletBackend(scene.paper(), gui=args.gui, arm="ready") as robot:
        # the arm starts at a seeded random point above the grid, 8-15 cm above the paper
        rng = np.random.default_rng(args.seed)
        right, far = rng.uniform(-scene.grid_size / 2, scene.grid_size / 2, size=2)
        robot.reset_hand(scene.grid_to_world(right, far) + np.array([0.0, 0.0, rng.uniform(0.08, 0.15)]))
        if args.opponent_cell:
            for stroke in cross_strokes(scene, args.opponent_cell, np.random.default_rng(args.seed)):
                robot.ink.ink_polyline(stroke, color="opponent")
        circle = circle_path(scene, args.cell, 0.32 * cell)
        lift = np.array([0.0, 0.0, 0.03])
        robot.move(np.array([circle[0] + lift, circle[0]]), label="reach")
        half = len(circle) // 2
        robot.move(circle[: half + 1], pen_down=True, label="draw circle")
        eye = robot.eyes.camera_image(args.eye)
        robot.move(circle[half:], pen_down=True, label="draw circle")
        robot.move(np.array([circle[-1] + lift, cell_center(scene, args.cell) + 4 * lift]), label="retract")
        # park beside the board (to the robot's right, near side) so the top view sees it all
        half_grid = scene.grid_size / 2
        robot.move(np.array([scene.grid_to_world(half_grid + 0.06, -half_grid) + 4 * lift]), label="park")
        top = robot.overview.top_view_image(args.size)
    eye_path = out / f"eye_{args.eye}.png"
    top_path = out / "board_top.png"
    write_png(eye_path, eye.rgb)
    write_png(top_path, top.rgb)
    print(eye_path)
    print(top_path)
    return 0
