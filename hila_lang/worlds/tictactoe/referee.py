"""The referee: the game as it really is, the opponent's moves, the perturbations, the scores.

The :class:`Referee` keeps the game's record (:class:`Record`: the board and the moves as they
really are; sealed while the robot decides: reading it then is an error) and the sheet's true place, plays the opponent's moves on the real board (inking
its crosses, neat or sloppy), perturbs the scene between moves and scores what the robot did
and saw.  It never chooses, filters or retries for the robot: the robot's decisions come from
its own sightings (:mod:`.player`), and the game goes on from them.  The referee compares
after the fact:

- each sighting against what the paper holds (:meth:`Referee.paper_marks`: the record, and the
  robot's marks drawn out of turn in empty cells, whose ink is there though the game does not
  count them) and the true sheet: ``misreads`` (cell, what the robot saw, what is there),
  ``unclear`` (cells whose ink the robot said it could not tell, ``"?"``: not guessed, so not a
  misread, but listed), the distances of the perceived grid corners from the true ones and of
  the estimated table height from the true one;
- each circle: the cell its ink lies in (on the sheet as it is), how far it strays outside it,
  and ``fouls`` (a circle drawn out of turn or in a taken cell; the record keeps the cell's
  first mark, and only the game's legal moves).

Perturbations (world settings, seeded by ``--seed``), after each of the opponent's moves:

- ``board.bump=D``: the sheet is pushed up to ``D`` metres from where it was laid out and turned
  up to 15 degrees (``15 * D / 0.03`` degrees below 3 cm);
- ``light=F``: the light changes to a seeded level between ``F`` and 1 of the original, from a
  seeded direction;
- ``crosses=sloppy``: the opponent's crosses are off-centre, turned and over a grid line
  (:func:`.marks.cross_strokes`).

And during each of the robot's pen-down strokes: ``board.slide=D``, ``board.turn=DEG``,
``board.jump=D`` (:class:`hila_lang.sim.motion.SheetMotion`, :attr:`Referee.motion`; the grid's
centre and turn are the sheet's pose, :func:`pose_of`); a circle drawn while
the sheet moved is scored where its ink lies on the sheet in its final position.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import replace
from typing import Any

import numpy as np

from ...core.errors import HilaRuntimeError
from ...sim.motion import carried, SheetMotion
from . import rules as ttt
from .board import cell_at, cell_corners, Grid
from .marks import cross_strokes, mark_correlation, on_paper, outside_cell, tracking_error
from .ownmark import inked_strokes

ROBOT, OPPONENT = "robot", "opponent"
#: the largest turn of a bumped sheet, degrees (reached at a push of BUMP_FULL metres)
BUMP_TURN_DEG = 15.0
BUMP_FULL = 0.03


class SealedRecordError(RuntimeError):
    """The game's record was read while the robot was deciding: a bug (the robot decides from
    what it sees, never from the record)."""


class Record:
    """The game as it really is: the board (9 marks) and the moves (dicts with ``player``,
    ``mark``, ``cell``, ``t``).

    While :meth:`sealed` (the world seals it while it answers the robot's questions and names
    the points the robot binds), reading or writing it raises :class:`SealedRecordError`.
    """

    def __init__(self) -> None:
        self._board: ttt.Board = ttt.empty_board()
        self._moves: list[dict[str, Any]] = []
        self._seals = 0

    def _open(self, what: str) -> None:
        if self._seals:
            raise SealedRecordError(f"the game's record ({what}) was read while the robot was deciding; "
                                    "its decisions come from what it sees")

    @property
    def board(self) -> ttt.Board:
        self._open("board")
        return self._board

    @board.setter
    def board(self, value: ttt.Board) -> None:
        self._open("board")
        self._board = tuple(value)

    @property
    def moves(self) -> list[dict[str, Any]]:
        self._open("moves")
        return self._moves

    @contextmanager
    def sealed(self):
        """Seal the record for the duration (re-entrant)."""
        self._seals += 1
        try:
            yield self
        finally:
            self._seals -= 1


class Referee:
    """Keeps the record, plays the opponent, perturbs the scene and scores (module docstring).

    Parameters
    ----------
    layout : Grid
        Where the sheet was laid out.
    first : {"robot", "opponent"}
    seed : int
    bump : float
        ``board.bump``, metres (0: the sheet stays).
    light : float
        ``light`` (1: steady).
    sloppy : bool
        ``crosses=sloppy``.
    """

    def __init__(self, layout: Grid, first: str, seed: int, *, bump: float = 0.0, light: float = 1.0,
                 sloppy: bool = False, slide: float = 0.0, turn: float = 0.0, jump: float = 0.0) -> None:
        self.layout = layout
        self.grid = layout
        self.first = first
        self.bump, self.light, self.sloppy = float(bump), float(light), bool(sloppy)
        self.rng = np.random.default_rng([int(seed), 14, 1])
        #: the sheet's moves while the robot draws (its own generator: the other draws stay as they were)
        self.motion = SheetMotion(pose_of(layout), np.random.default_rng([int(seed), 34]), slide=slide, turn=turn,
                                  jump=jump)
        self.record = Record()
        self.backend = None
        self.marks: list[dict[str, Any]] = []      # the robot's circles, scored
        self.crosses: list[list[np.ndarray]] = []  # the opponent's strokes, per move
        self.looks: list[dict[str, Any]] = []      # per sighting: its score
        self.misreads: list[dict[str, Any]] = []
        self.unclear: list[dict[str, Any]] = []
        self.fouls: list[dict[str, Any]] = []
        self.perturbations: list[dict[str, Any]] = []
        #: cell -> mark inked on the paper outside the game's record (a circle drawn out of turn)
        self.stray: dict[int, str] = {}

    # -- the game as it is ---------------------------------------------------------------------
    def to_move(self) -> str | None:
        """Whose turn it really is, or None when the game is over."""
        board = self.record.board
        if ttt.game_over(board):
            return None
        placed = 9 - board.count(ttt.EMPTY)
        return ROBOT if (placed % 2 == 0) == (self.first == ROBOT) else OPPONENT

    def result(self) -> str | None:
        """``"robot"``, ``"opponent"``, ``"draw"``, or None while the game goes on."""
        w = ttt.winner(self.record.board)
        if w == ttt.CIRCLE:
            return ROBOT
        if w == ttt.CROSS:
            return OPPONENT
        return "draw" if ttt.EMPTY not in self.record.board else None

    def paper_marks(self) -> ttt.Board:
        """What the paper holds, cells 1..9: the record's marks, and where the record has none, a
        circle the robot drew out of turn (:attr:`stray`): what an eye that reads right sees."""
        return tuple(m or self.stray.get(c, "") for c, m in enumerate(self.record.board, 1))

    def _record(self, who: str, cell: int, t: float) -> None:
        mark = ttt.CIRCLE if who == ROBOT else ttt.CROSS
        self.record.board = ttt.play(self.record.board, cell, mark)
        self.record.moves.append({"player": who, "mark": mark, "cell": cell, "t": round(t, 3)})

    # -- the opponent and the scene ------------------------------------------------------------
    def opponent_moves(self, opponent, t: float) -> int:
        """The opponent plays on the real board; its cross is inked on the paper."""
        cell = int(opponent.choose(self.record.board))
        strokes = cross_strokes(self.grid, cell, self.rng, sloppy=self.sloppy)
        ink = None if self.backend is None else self.backend.ink
        if ink is not None:
            for stroke in strokes:
                ink.ink_polyline(stroke)
        self.crosses.append(strokes)
        self._record(OPPONENT, cell, t)
        return cell

    def perturb(self) -> dict[str, Any] | None:
        """Between moves: push and turn the sheet (``board.bump``), change the light (``light``)."""
        event: dict[str, Any] = {}
        moves = len(self.record.moves)
        if self.bump > 0:
            r = self.bump * math.sqrt(self.rng.uniform())
            a = self.rng.uniform(0.0, 2 * math.pi)
            turn = math.radians(BUMP_TURN_DEG * min(1.0, self.bump / BUMP_FULL)) * self.rng.uniform(-1.0, 1.0)
            cx, cy = self.layout.grid_center
            self.grid = replace(self.layout, grid_center=(cx + r * math.cos(a), cy + r * math.sin(a)),
                                grid_rotation=self.layout.grid_rotation + turn)
            self.backend.ink.move_to(self.grid.paper(printed=False))
            event["board"] = {"shift_mm": round(1000 * r, 2), "turn_deg": round(math.degrees(turn), 2)}
        if self.light != 1.0:
            level = self.rng.uniform(min(self.light, 1.0), max(self.light, 1.0))
            azimuth, elevation = self.rng.uniform(0, 2 * math.pi), self.rng.uniform(math.radians(40), math.radians(85))
            direction = (math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
                         math.sin(elevation))
            self.backend.lighting.set_light(level, direction)
            event["light"] = {"level": round(level, 3), "direction": [round(v, 3) for v in direction]}
        if not event:
            return None
        event["after_move"] = moves
        self.perturbations.append(event)
        return event

    # -- scoring -------------------------------------------------------------------------------
    def score_sighting(self, sight: dict[str, Any]) -> list[dict[str, Any]]:
        """Compare one sighting with the paper (:meth:`paper_marks`) and the sheet as they are now;
        returns its misreads."""
        truth = self.paper_marks()
        misreads = [{"look": sight["look"], "moves_before": len(self.record.moves), "cell": c,
                     "seen": sight["board"][c - 1], "true": truth[c - 1]}
                    for c in range(1, 10) if sight["board"][c - 1] not in (truth[c - 1], ttt.UNCLEAR)]
        self.unclear += [{"look": sight["look"], "moves_before": len(self.record.moves), "cell": c, "true": truth[c - 1]}
                         for c in range(1, 10) if sight["board"][c - 1] == ttt.UNCLEAR]
        errors = corner_errors(sight["corners"], self.grid)
        self.looks.append({"look": sight["look"], "moves_before": len(self.record.moves),
                           "views": [v["view"] for v in sight["views"]], "arm": sight["arm"],
                           "unsure": list(sight["unsure"]), "misreads": len(misreads),
                           "board": list(sight["board"]),
                           "corner_error_median_m": float(np.median(errors)),
                           "corner_error_max_m": float(errors.max()), "corner_errors_m": errors,
                           "table_error_m": float(sight["surface_z"] - self.grid.surface_z),
                           "seconds": sight["seconds"]})
        self.misreads += misreads
        return misreads

    def score_circle(self, entry: dict[str, Any], template=None, intended: int | None = None,
                     t: float = 0.0) -> dict[str, Any]:
        """Score the robot's circle (a finished pen-down state) and record it where its ink is."""
        drawn = entry["executed"] if entry["executed"] is not None else entry["planned"]
        if drawn is None or len(drawn) == 0:
            raise HilaRuntimeError("the robot drew, but the back end reported no path", state=entry["state"])
        if entry.get("during"):  # the sheet moved under the pen: the ink where it lies on the sheet now
            drawn = carried(drawn, entry["during"], pose_of(self.grid))
        touching = on_paper(drawn, self.grid.surface_z)
        ink = touching if len(touching) >= 3 else drawn
        cell = cell_at(self.grid, np.median(ink, axis=0))
        if cell is None:
            raise HilaRuntimeError("the robot drew its circle outside the grid", state=entry["state"])

        strokes = [] if template is None else inked_strokes(template)
        demo_circle = np.vstack(strokes) if strokes else None  # the demonstrated ink, in its paper's plane
        planned = entry["planned"]
        planned_circle = None if planned is None else on_paper(planned, self.grid.surface_z)

        def r_of(circle):
            ok = demo_circle is not None and circle is not None and len(circle) >= 4 and len(demo_circle) >= 4
            return mark_correlation(np.asarray(circle)[:, :2], demo_circle) if ok else None

        mark = {"cell": cell, "intended_cell": intended, "state": entry["state"], "planned": planned,
                "executed": drawn, "contact_points": int(len(touching)),
                "outside_cell_m": outside_cell(self.grid, cell, ink), "r": r_of(touching),
                "r_planned": r_of(planned_circle)}
        if entry["planned"] is not None and entry["executed"] is not None:
            err = tracking_error(entry["planned"], entry["executed"], prefix=True)
            mark["tracking_median_m"] = float(np.median(err))
            mark["tracking_max_m"] = float(err.max())
        self.marks.append(mark)
        if self.record.board[cell - 1] != ttt.EMPTY:
            self.fouls.append({"cell": cell, "foul": f"drawn over {self.record.board[cell - 1]}",
                               "moves_before": len(self.record.moves)})
        elif self.to_move() != ROBOT:
            self.fouls.append({"cell": cell, "foul": "drawn out of turn", "moves_before": len(self.record.moves)})
            self.stray.setdefault(cell, ttt.CIRCLE)  # its ink is on the paper all the same
        else:
            self._record(ROBOT, cell, t)
        return mark


def pose_of(grid: Grid) -> tuple:
    """The sheet's pose (x, y, rotation) as :mod:`hila_lang.sim.motion` moves it: the grid's centre and turn."""
    return (grid.grid_center[0], grid.grid_center[1], grid.grid_rotation)


def grid_at(layout: Grid, pose: tuple) -> Grid:
    """``layout`` moved to ``pose`` (x, y, rotation)."""
    return replace(layout, grid_center=(pose[0], pose[1]), grid_rotation=pose[2])


def corner_errors(corners: dict[int, dict[str, np.ndarray]], grid: Grid) -> np.ndarray:
    """Distances (16,), metres, of the perceived grid corners (the 4 x 4 points where the cells
    meet) from the true ones on ``grid``."""
    out = {}
    for cell in range(1, 10):
        for name, true in cell_corners(grid, cell).items():
            out[tuple(np.round(true, 6))] = float(np.linalg.norm(np.asarray(corners[cell][name]) - true))
    return np.array(list(out.values()))
