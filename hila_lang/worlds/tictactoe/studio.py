"""Tic-tac-toe in ``hila studio`` (:class:`~hila_lang.plugins.studio.StudioView`, ``WORLD.studio``).

- :func:`scene`: the demonstration sheet as the iCub's left eye sees it while it watches
  (:func:`.recording.demonstration_rig`), at twice the eye's resolution, with the map from the
  paper's plane to the picture (the paper is flat, so the eye's pinhole maps it by a homography,
  :func:`.reading.plane_to_image_homography`), every cell corner as a point an ICP snaps to, and
  the pen lifted between strokes no higher than the arm's highest park above the paper
  (:data:`.world.PARK_HEIGHT`);
- :func:`board`: the game's board, a cell a button, a free cell answered by its number (what the
  human opponent types, :class:`.opponents.HumanOpponent`).
"""

from __future__ import annotations

import functools

from ...plugins.studio import Board, DrawingScene
from .board import Grid, cell_corners
from .reading import plane_to_image_homography


def features(spec: Grid) -> tuple:
    """Every cell's corners (the grid's 16 line crossings, each named by every cell it is a corner
    of: ``cell5.tl`` is ``cell1.br``), as the places an ICP snaps to."""
    return tuple((f"cell{cell}.{corner}", tuple(float(v) for v in p))
                 for cell in range(1, 10) for corner, p in cell_corners(spec, cell).items())


@functools.lru_cache(maxsize=1)
def scene() -> DrawingScene:
    """The demonstration sheet seen by the left eye (rendered once per process: it starts a
    PyBullet client)."""
    from ...core.fileio import png_bytes
    from .recording import DemonstrationScene, demonstration_rig
    from .world import PARK_HEIGHT

    spec = Grid.demonstration()
    eye = demonstration_rig(spec).left
    camera = eye.with_size(eye.width * 2, eye.height * 2, scale=2.0)
    with DemonstrationScene(spec, marker=False) as sc:
        rgb = sc.render(camera)
    H = plane_to_image_homography(camera.K, camera.world_T_camera, spec.surface_z)
    return DrawingScene(png_bytes(rgb), camera.width, camera.height, H / H[2, 2], spec.surface_z, features(spec),
                        lift=max(PARK_HEIGHT))


def board(world) -> Board:
    """The board the referee keeps: marks as labels, free cells answered by their number."""
    marks = [str(m) for m in world.board]
    return Board(3, tuple(marks), tuple(None if m else str(i + 1) for i, m in enumerate(marks)))
