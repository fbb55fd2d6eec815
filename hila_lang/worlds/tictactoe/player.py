"""The robot's side of the game: what it saw and did, and what it decides from that.

:class:`Player` is built with the robot's eyes (or none), its arm (:class:`Hand`: where the pen
is, and moving it to look) and what it was told when the game was set up: who starts, where its
arm was parked, and -- for a robot without eyes only -- the board's geometry as it was laid out.
It has no handle on the game's record, the referee or the simulator.  Every decision comes from
its own sightings and memory:

- what is on the board: its latest sighting (:func:`.vision.look_at_board`), each mark told
  apart by the robot's own mark (:attr:`Player.mark`: what its program's template inks, see
  :mod:`.ownmark`); a robot without eyes plays blind, from the moves it made and the moves the
  opponent announced;
- whose turn it is: the marks it sees (with the robot first, its turn when it sees as many of
  its own marks as crosses; with a cell it could not tell, when it sees an even number of
  marks), and whether the game is over: three in a row or a full board, as seen;
- the cell it plays: minimax on the board it sees (:func:`.rules.best_move`);
- the corners it binds (the ICPs ``board.cellN.*``): the grid as it sees it, :data:`PEN_PRESS`
  below the paper it sees (a hand pressing its pen: the table's height is an estimate), else
  the layout.

It looks again whenever something may have changed since its last look: after each of its own
circles and each move the opponent announces (it does not know when the board is pushed: it
notices a moved board because it looks before every decision that follows a move).  While it
draws with a ``track`` clause it glances at the grid with one eye at every tick
(:class:`~.tracking.SheetTracker`): the corners it binds are then the grid where it last glanced
it, until its next full look.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial
from typing import Any, Callable

import numpy as np

from ...core.errors import HilaRuntimeError
from . import rules as ttt
from .board import cell_at, cell_corners, cell_number, Grid
from .ownmark import KeptReadings
from .reading import read_board
from .tracking import SheetTracker
from .vision import look_at_board, Memory, Table, TABLE_PRIOR_BELOW_GAZE

ROBOT, OPPONENT = "robot", "opponent"
#: how far beyond the grid's right edge the pen goes to take the arm out of the eyes' view, metres
ASIDE_MARGIN = 0.06
#: before the robot has seen the board, "aside" is this far from where its eyes look
#: (to its right and nearer; the same place as beside a board there), metres
ASIDE_UNSEEN = np.array([-0.04, -0.16, 0.0])
#: the pen's executed path within this height of its lowest point is where it drew, metres
DRAWN_BAND = 0.003
#: the robot aims its pen this far below the paper it sees, metres: a table height estimated
#: up to 0.5 mm too high still inks (the pen inks within 0.5 mm), and up to 1.5 mm too low is
#: still within the 2 mm the arm may push into the table (measured estimates: within 0.6 mm)
PEN_PRESS = 0.0005


@dataclass(frozen=True)
class Hand:
    """The robot's arm as the player uses it: ``position() -> (3,)`` (the pen tip, from the
    robot's own joints) and ``move(path (T, 3))``."""

    position: Callable[[], np.ndarray]
    move: Callable[[np.ndarray], Any]


class Player:
    """The robot's side of one game (see the module docstring).

    Parameters
    ----------
    first : {"robot", "opponent"}
        Who starts (agreed when the game was set up).
    park : ndarray, shape (3,)
        Where the arm was parked at the start.
    eyes : Eyes or None
        The robot's eyes (``backend.eyes``); None: it plays blind.
    hand : Hand or None
        Needed with eyes (to move the arm out of the way).
    layout : Grid or None
        Where the board was laid out, for a robot without eyes (default :meth:`Grid.game`); a
        robot with eyes is given none: it knows the board only from its sightings.
    table_prior : float or None
        The table's height the robot assumes before its eyes measure it (its spec's
        ``table_prior``, :mod:`hila_lang.robot.spec`); None: a little below where its eyes look.

    Attributes
    ----------
    sightings : list of dict
        One per look: ``look`` (its number), ``board``, ``corners``, ``center``, ``views``,
        ``arm``, ``unsure``, ``doubts``, ``surface_z``, ``marks_made`` (marks made since the
        look before, as far as the robot knows) and ``seconds``.
    own : list of int
        The cells of its circles, where it drew them in the grid as it saw it.
    choice : int or None
        The cell it chose last.
    mark : OwnMark or None
        Its own mark, as its program draws it (:class:`.ownmark.OwnMark`; the world sets it when
        the program is known); None: any mark it sees is the opponent's.
    readings : KeptReadings or None
        Its mark with the memory its looks read cells through (:class:`.ownmark.KeptReadings`:
        a cell's sure reading kept while its ink stays the same); None before its first look.
    """

    def __init__(self, first: str, park: np.ndarray, *, eyes=None, hand: Hand | None = None,
                 layout: Grid | None = None, table_prior: float | None = None) -> None:
        self.first = first
        self.park = np.asarray(park, dtype=float).copy()
        self.eyes, self.hand = eyes, hand
        self.layout = layout if layout is not None or eyes is not None else Grid.game()
        if table_prior is None:  # no spec says: a little below where the eyes look
            table_prior = float(eyes.target[2]) - TABLE_PRIOR_BELOW_GAZE if eyes is not None else float("nan")
        self.table = Table(table_prior)
        self.sightings: list[dict[str, Any]] = []
        self.own: list[int] = []
        self.choice: int | None = None
        self.mark = None
        self.readings = None
        self._blind_board: ttt.Board = ttt.empty_board()
        self._since = 0
        self._stale = True
        #: the grid's corners from its latest glance while drawing (None: its last look is newer)
        self.glanced: dict | None = None
        self.tracker = None
        #: every glance (:attr:`.tracking.SheetTracker.glances`)
        self.glances: list[dict] = []

    @property
    def sees(self) -> bool:
        return self.eyes is not None

    # -- what happens --------------------------------------------------------------------------
    def opponent_moved(self, announced: int | None = None) -> None:
        """The opponent says it has moved.  A robot without eyes takes the announced cell; one
        with eyes only notes that a mark was made and looks before its next decision."""
        self._since += 1
        self._stale = True
        if not self.sees and announced is not None and self._blind_board[announced - 1] == ttt.EMPTY:
            self._blind_board = ttt.play(self._blind_board, int(announced), ttt.CROSS)

    def drew(self, commanded: np.ndarray) -> int | None:
        """The robot drew a circle along ``commanded`` (T, 3), the pen path it sent to its arm:
        remember the cell it drew in, as it sees the board; returns it (None: not in the grid as
        it sees it)."""
        path = np.asarray(commanded, dtype=float)
        low = path[path[:, 2] <= path[:, 2].min() + DRAWN_BAND]
        cell = self._cell_at(np.median(low, axis=0))
        self._since += 1
        self._stale = True
        if cell is not None:
            self.own.append(cell)
            if not self.sees and self._blind_board[cell - 1] == ttt.EMPTY:
                self._blind_board = ttt.play(self._blind_board, cell, ttt.CIRCLE)
        return cell

    # -- what it sees ----------------------------------------------------------------------------
    def sight(self) -> dict[str, Any] | None:
        """The latest sighting, looking first when something may have changed since the last
        one (or it never looked).  None without eyes."""
        if not self.sees:
            return None
        if not self._stale and self.sightings:
            return self.sightings[-1]

        clock = time.perf_counter()
        last = self.sightings[-1] if self.sightings else None
        memory = Memory(None if last is None else tuple(last["board"]), None if last is None else self._since)

        if self.mark is not None and (self.readings is None or self.readings.mark is not self.mark):
            self.readings = KeptReadings(self.mark)
        seen = look_at_board(self.eyes, self.hand, self.table, memory, self.lift_point(), self.aside_point(),
                             read=partial(read_board, own=None if self.mark is None else self.readings))
        entry = {"look": len(self.sightings) + 1, "marks_made": self._since, "board": seen.board,
                 "corners": seen.corners, "center": seen.center, "views": seen.views, "arm": seen.arm,
                 "unsure": seen.unsure, "doubts": seen.doubts, "surface_z": seen.surface_z,
                 "seconds": time.perf_counter() - clock}
        self.sightings.append(entry)
        self._since, self._stale = 0, False
        self.glanced = None
        return entry

    def board(self) -> ttt.Board:
        """The board as the robot knows it: seen, or (blind) from the moves it knows of."""
        sight = self.sight()
        return self._blind_board if sight is None else tuple(sight["board"])

    def corners(self) -> dict[int, dict[str, np.ndarray]]:
        """Cell (1..9) -> ``tl|tr|br|bl`` -> point (3,), metres, to bind: as seen (pressed
        :data:`PEN_PRESS` into the paper), else the layout."""
        sight = self.sight()
        if sight is None:
            if self.layout is None:
                raise HilaRuntimeError("the robot has not seen the board yet: it has no corners to bind")
            return {cell: cell_corners(self.layout, cell) for cell in range(1, 10)}
        press = np.array([0.0, 0.0, PEN_PRESS])
        return {cell: {name: p - press for name, p in names.items()} for cell, names in self._known().items()}

    def _known(self) -> dict[int, dict[str, np.ndarray]]:
        """The grid's corners as the robot last perceived them: its latest glance, else its latest look."""
        return self.glanced if self.glanced is not None else self.sightings[-1]["corners"]

    # -- following the sheet while drawing (a ``track`` clause) --------------------------------------
    def track_begin(self) -> None:
        """A tracked step begins: follow the grid from where the robot knows it to be."""
        self.tracker = None if not self.sees or not self.sightings else SheetTracker(self._known(), self.table.z)

    def glance(self) -> None:
        """One look with the left eye while drawing: the grid where it is now, as far as it shows."""
        if self.tracker is None:
            return
        corners = self.tracker.glance(self.eyes)
        self.glances.append(self.tracker.glances[-1])
        if corners is not None:
            self.glanced = corners

    def track_end(self) -> None:
        self.tracker = None

    # -- decisions -------------------------------------------------------------------------------
    def to_move(self) -> str | None:
        """``"robot"``, ``"opponent"`` or None (game over), from the marks it knows of."""
        board = self.board()
        if ttt.game_over(board):
            return None
        circles, crosses = board.count(ttt.CIRCLE), board.count(ttt.CROSS)
        if ttt.UNCLEAR in board:  # a mark it could not tell: the count of marks says whose turn it is
            placed = 9 - board.count(ttt.EMPTY)
            return ROBOT if (placed % 2 == 0) == (self.first == ROBOT) else OPPONENT
        if self.first == ROBOT:
            return ROBOT if circles <= crosses else OPPONENT
        return ROBOT if crosses > circles else OPPONENT

    def game_over(self) -> bool:
        return ttt.game_over(self.board())

    def best_move(self) -> int:
        """Its minimax move on the board it knows (centre first among equals)."""
        board = self.board()
        if ttt.game_over(board):
            raise HilaRuntimeError("the game is over: the robot has no move to make")
        self.choice = ttt.best_move(board, ttt.CIRCLE)
        return self.choice

    def last_move(self) -> int:
        if not self.own:
            raise HilaRuntimeError("the robot has not drawn a mark yet: there is no last move")
        return self.own[-1]

    # -- where the arm goes ------------------------------------------------------------------------
    def lift_point(self) -> np.ndarray:
        """Straight above the pen at the park height, shape (3,): the hand's start of a reach.

        After a circle the pen is low over the paper; a reach warped from there would squash
        the demonstrated approach flat onto the paper, so each reach starts from this point
        (the back end lifts the pen straight up to it).  Without an arm it is the park.
        """
        here = self.park if self.hand is None else np.asarray(self.hand.position(), dtype=float)
        return np.array([here[0], here[1], max(float(here[2]), float(self.park[2]))])

    def aside_point(self) -> np.ndarray:
        """Where the pen goes so that the arm is out of the eyes' view of the board, shape (3,):
        beyond the near-right corner of the grid as last seen (the arm's side), at the park
        height; before the first sighting, beside where the eyes look (the back end first aims
        them at the middle of the sheet it was handed: where to look, not what is there)."""
        if self.sightings:
            c = self._known()
            right = c[9]["br"] - c[9]["bl"]
            point = c[9]["br"] + ASIDE_MARGIN * right / np.linalg.norm(right)
        else:
            point = np.asarray(self.eyes.target, dtype=float) + ASIDE_UNSEEN
        return np.array([point[0], point[1], self.park[2]])

    def _cell_at(self, point: np.ndarray) -> int | None:
        """The cell (1..9) holding ``point`` in the grid as the robot knows it, or None."""
        if not self.sightings:
            return None if self.layout is None else cell_at(self.layout, point)
        c = self._known()
        origin = c[1]["tl"]
        right = c[3]["tr"] - origin
        near = c[7]["bl"] - origin
        rel = np.asarray(point, dtype=float)[:2] - origin[:2]
        u = rel @ right[:2] / (right[:2] @ right[:2]) * 3
        v = rel @ near[:2] / (near[:2] @ near[:2]) * 3
        return int(cell_number(u, v)) or None

