"""Whole games of programs/game.hila on the PyBullet iCub, checked by vision.

The robot's own eye camera reads the final board (``hila_lang.perception.board.read_board``,
OpenCV): which cells hold a circle and which a cross must equal the game's own board.  The
paper's ink (the texture the cameras see) shows every circle inside its cell.  The robot never
loses and every drawn circle correlates with the demonstrated one (R >= 0.95).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")
cv2 = pytest.importorskip("cv2")

from hila_lang.language.plugins import RunOptions  # noqa: E402
from hila_lang.language.runner import finish, prepare  # noqa: E402
from hila_lang.perception.board import read_board  # noqa: E402
from hila_lang.robot.ink import PIXELS_PER_METRE  # noqa: E402
from hila_lang.robot.scene import cell_at  # noqa: E402

PROGRAM = Path(__file__).resolve().parents[1] / "programs" / "game.hila"


def robot_ink_cells(ink_rgb: np.ndarray, scene) -> list[set]:
    """Per blob of the robot's (blue) ink on the paper texture, the set of cells its pixels lie in."""
    rgb = ink_rgb.astype(int)
    blue = (rgb[:, :, 2] > 120) & (rgb[:, :, 0] < 110) & (rgb[:, :, 2] - rgb[:, :, 0] > 60)
    count, labels = cv2.connectedComponents(blue.astype(np.uint8), connectivity=8)
    across, depth = scene.paper_size
    blobs = []
    for k in range(1, count):
        rows, cols = np.nonzero(labels == k)
        if len(rows) < 10:
            continue
        right = (cols + 0.5) / PIXELS_PER_METRE - across / 2
        far = depth / 2 - (rows + 0.5) / PIXELS_PER_METRE
        pts = scene.grid_to_world(right, far)
        blobs.append({cell_at(scene, p) for p in pts})
    return blobs


@pytest.mark.parametrize("opponent", ["random", "minimax"])
@pytest.mark.parametrize("seed", [0, 1, 4])
def test_whole_game_read_by_the_robots_eye(tmp_path, seed, opponent):
    options = RunOptions(seed=seed, out=tmp_path / "out", opponent=opponent,
                         stdin=io.StringIO(), stdout=io.StringIO())
    interp = prepare(PROGRAM, options, "pybullet")
    try:
        interp.run()
        world, backend = interp.world, interp.backend
        eye = backend.camera_image("left")
        ink = backend.ink_image()
    finally:
        report = finish(interp)
    # the robot never loses; perfect play on both sides draws
    assert report["result"] in ("robot", "draw")
    if opponent == "minimax":
        assert report["result"] == "draw"
    # vision: the eye camera's reading of the final board equals the game's board
    reading = read_board(eye, world.scene.surface_z)
    assert reading.marks == list(world.board)
    # vision: each circle of ink lies inside exactly one cell, one circle per robot move
    blobs = robot_ink_cells(ink, world.scene)
    robot_cells = sorted(m["cell"] for m in report["moves"] if m["player"] == "robot")
    assert all(len(b) == 1 and None not in b for b in blobs), blobs
    assert sorted(next(iter(b)) for b in blobs) == robot_cells
    # the drawn circles correlate with the demonstrated one; the pen followed the plan
    assert all(m["r"] >= 0.95 for m in report["marks"])
    assert report["tracking_error_mm"]["max"] < 3.0
    saved = json.loads((Path(report["out"]) / "report.json").read_text())
    assert {"eye.png", "top.png", "traces.csv", "report.json"} <= set(saved["files"])
