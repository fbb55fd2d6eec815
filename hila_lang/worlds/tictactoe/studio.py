"""Tic-tac-toe in ``hila studio`` (:class:`~hila_lang.plugins.studio.StudioView`, ``WORLD.studio``).

- :func:`scene`: the demonstration sheet as the iCub's left eye sees it while it watches
  (:func:`.recording.demonstration_rig`), at twice the eye's resolution, with the map from the
  paper's plane to the picture (the paper is flat, so the eye's pinhole maps it by a homography,
  :func:`.reading.plane_to_image_homography`), every cell corner as a point an ICP snaps to, and
  the pen lifted between strokes no higher than the arm's highest park above the paper
  (:data:`.world.PARK_HEIGHT`);
- :func:`board`: the game's board, a cell a button: what the paper holds (the referee's record,
  and a mark the robot drew out of turn, noted as not counted), a cell the robot's last look read
  otherwise noted with what it read (the report's ``vision`` misreads, and cells it could not
  tell); a free cell answered by its number (what the human opponent types,
  :class:`.opponents.HumanOpponent`);
- :func:`outcome`: who won, in the words ``hila exec`` ends the game with (the report's ``result``).
"""

from __future__ import annotations

import functools

from ...core.fileio import png_bytes
from ...plugins.studio import Board, DrawingScene
from .board import cell_corners, Grid
from .reading import plane_to_image_homography
from .recording import demonstration_rig, DemonstrationScene
from .world import PARK_HEIGHT, RESULT_WORDS


def features(spec: Grid) -> tuple:
    """Every cell's corners (the grid's 16 line crossings, each named by every cell it is a corner
    of: ``cell5.tl`` is ``cell1.br``), as the places an ICP snaps to."""
    return tuple((f"cell{cell}.{corner}", tuple(float(v) for v in p))
                 for cell in range(1, 10) for corner, p in cell_corners(spec, cell).items())


@functools.lru_cache(maxsize=1)
def scene() -> DrawingScene:
    """The demonstration sheet seen by the left eye (rendered once per process: it starts a
    PyBullet client)."""
    spec = Grid.demonstration()
    eye = demonstration_rig(spec).left
    camera = eye.with_size(eye.width * 2, eye.height * 2, scale=2.0)
    with DemonstrationScene(spec, marker=False) as sc:
        rgb = sc.render(camera)
    H = plane_to_image_homography(camera.K, camera.world_T_camera, spec.surface_z)
    return DrawingScene(png_bytes(rgb), camera.width, camera.height, H / H[2, 2], spec.surface_z, features(spec),
                        lift=max(PARK_HEIGHT))


def board(world) -> Board:
    """What the paper holds as labels (:meth:`.referee.Referee.paper_marks`), free cells of the
    record answered by their number, and a note on a cell the record does not count or the robot's
    latest scored look read otherwise (its misreads and unclear cells, as the report lists them)."""
    referee, record = world.referee, [str(m) for m in world.board]
    paper = [str(m) for m in referee.paper_marks()]
    notes: list[str | None] = [None if p == r else "drawn out of turn: the game does not count it"
                               for p, r in zip(paper, record)]
    last = referee.looks[-1]["look"] if referee.looks else None
    for m in referee.misreads:
        if m["look"] == last:
            notes[m["cell"] - 1] = f"the robot read {m['seen'] or 'nothing'} here at look {last}"
    for u in getattr(referee, "unclear", ()):  # cells the robot said it could not tell (not guessed)
        if u["look"] == last:
            notes[u["cell"] - 1] = f"the robot could not tell this ink at look {last}"
    return Board(3, tuple(paper), tuple(None if m else str(i + 1) for i, m in enumerate(record)), tuple(notes))


def outcome(world) -> str:
    """The finished program's game in words: who won, a draw, or why it is unfinished."""
    return RESULT_WORDS[world.result()] + world._why_unfinished(world.result())
