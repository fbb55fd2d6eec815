"""The ``tictactoe`` world that ``programs/game.hila`` runs in (the paper's Experiment B).

The iCub plays circles (``O``) on :meth:`Grid.game` -- a grid 20 % smaller than the
demonstration's, rotated and 0.20 m higher -- against an opponent who plays crosses (``X``).

Scene points (:meth:`TicTacToeWorld.points`), world frame, metres:

- ``board.cellN.tl|tr|br|bl`` for N = 1..9: every cell's corners;
- ``board.move.tl|tr|br|bl``: the corners of the cell the robot plays next (minimax, never
  loses; present only while it is the robot's turn);
- ``arm.park``: where the arm was parked at the start, a seeded random place above the grid;
- ``arm.lift``: straight above the pen at the park height (see :meth:`TicTacToeWorld.lift_point`).

Questions (:meth:`TicTacToeWorld.query`): ``game_over``, ``robot_to_move``, ``opponent_to_move``,
``best_move`` (the robot's next cell as a point group, ``"board.cell5"``, so ``c.*`` binds the
ICPs ``tl``, ``tr``, ``br``, ``bl`` to its corners), ``best_cell`` (the same as a number),
``last_move`` (the point group of the robot's last circle), ``winner`` (``"robot"``,
``"opponent"``, ``"draw"`` or None), ``marks`` (number of marks on the board), ``free N``
(cell N is empty).

Events: ``wait("opponent_moved")`` asks the opponent for a cell, inks its cross on the paper and
returns the cell.  ``notify("state_done", pen_down=True, executed=TRACE, ...)`` records the robot's
circle in the cell where the pen actually drew.  The board is printed after every move.

Seeing the board (issue 6, item 5).  With a back end that has eyes (``backend.eyes``:
PyBullet) the robot reads the board through them before each of its moves
(:func:`hila_lang.worlds.tictactoe.vision.look_at_board`): the left eye first; when the arm hides a cell or
the reading differs from the record, the pen is lifted straight up to ``arm.lift`` (where the
next reach starts anyway) and the left eye looks again; as a last resort the pen goes aside
(:meth:`TicTacToeWorld.aside_point`), both eyes look, and it comes back to ``arm.lift``.  The corners it finds are the scene points
``board.cellN.*`` and ``board.move.*`` (the ICPs the program binds), and minimax plays on the
marks it reads.  A reading that differs from the game's own record (a misread or an uninked mark)
is a :class:`~hila_lang.errors.HilaRuntimeError` naming the cells.  With the dry back end (no
cameras) the corners come from the known geometry (:meth:`Grid.game`) and the board from
the game's memory.  ``report.json`` says which (``vision``), with the largest distance of a
perceived corner from the true one.

Settings (``--set key=value``, declared in :mod:`hila_lang.worlds.tictactoe`):
``opponent=random|minimax|human`` (default minimax; ``--opponent`` is an alias),
``first=robot|opponent`` (default robot, as in the paper), ``report=yes|no`` (write the output
folder, default yes).  Each circle is compared with the
demonstration it was warped from: the path of the program's pen-down sub-template.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ...errors import HilaRuntimeError, InputError, UnknownNameError
from ...sim.surface import Scene
from .board import Grid, cell_at, cell_corners
from . import rules as ttt
from .marks import cross_strokes, on_paper
from .opponents import make_opponent

#: park height above the paper, metres (low, high)
PARK_HEIGHT = (0.08, 0.13)
ROBOT, OPPONENT = "robot", "opponent"
#: how far beyond the grid's right edge the pen goes to take the arm out of the eyes' view, metres
ASIDE_MARGIN = 0.06


def park_position(spec: Grid, rng: np.random.Generator) -> np.ndarray:
    """A seeded random place above the grid (within its middle 70 %), shape (3,), metres."""
    half = 0.35 * spec.grid_size
    right, far = rng.uniform(-half, half, size=2)
    point = spec.grid_to_world(right, far)
    point[2] += rng.uniform(*PARK_HEIGHT)
    return point


class TicTacToeWorld:
    """One game of tic-tac-toe between the robot and an opponent.

    Parameters
    ----------
    options : RunOptions
        ``seed``, ``out``, ``stdin``, ``stdout`` are used.
    settings : dict
        ``opponent``, ``first``, ``report``, parsed (see :data:`hila_lang.worlds.tictactoe.WORLD`).
    """

    def __init__(self, options, settings: dict[str, Any] | None = None) -> None:
        from . import WORLD

        self.t0 = time.perf_counter()
        self.options = options
        self.seed = int(options.seed)
        self.settings = {**WORLD.parse({}), **(settings or {})}
        self.spec = Grid.game()
        self.scene = Scene(surface=self.spec.paper())
        self.first = self.settings["first"]
        self.write_report = self.settings["report"]
        #: the output folder, made and proved writable now: a game is never played to be lost
        self.outputs = None
        if self.write_report:
            from .report import output_folder

            self.outputs = output_folder(options.out, self.seed)
        self.rng = np.random.default_rng([self.seed, 5])
        self.park = park_position(self.spec, self.rng)
        self.opponent = make_opponent(self.settings["opponent"], self.seed, options.stdin, options.stdout)
        self.stdout = options.stdout
        self.board: ttt.Board = ttt.empty_board()
        self.moves: list[dict[str, Any]] = []
        self.marks: list[dict[str, Any]] = []  # the robot's circles with their paths
        self.crosses: list[list[np.ndarray]] = []  # the opponent's ink strokes, per move
        self.states: list[dict[str, Any]] = []
        self.backend = None
        self.fsm = None
        #: what the eyes saw before each robot move: dicts with ``moves_before`` (moves played
        #: then), ``board`` (marks read), ``corners`` (cell -> name -> (3,)), ``views``, ``arm``,
        #: ``corner_error_m`` (against the true geometry) and ``seconds``
        self.sightings: list[dict[str, Any]] = []

    def _print(self, text: str = "") -> None:
        print(text, file=self.stdout, flush=True)

    # -- plug-in hooks -----------------------------------------------------------------------
    def attach(self, backend) -> None:
        """Park the arm at :attr:`park` (no drawing) and keep the back end for inking."""
        self.backend = backend
        backend.reset_hand(self.park)
        self._print(f"tic-tac-toe: the robot plays O, the opponent ({self.opponent.name}) plays X; "
                    f"{self.first} starts")
        self._print(ttt.render(self.board))

    # -- World protocol ----------------------------------------------------------------------
    def points(self) -> dict[str, np.ndarray]:
        corners = self.cell_corners()
        pts: dict[str, np.ndarray] = {"arm.park": self.park.copy(), "arm.lift": self.lift_point()}
        for cell in range(1, 10):
            for name, p in corners[cell].items():
                pts[f"board.cell{cell}.{name}"] = p.copy()
        if self.to_move() == ROBOT:
            for name, p in corners[self.best_move()].items():
                pts[f"board.move.{name}"] = p.copy()
        return pts

    # -- seeing the board ----------------------------------------------------------------------
    @property
    def sees(self) -> bool:
        """Whether the board is read through eye cameras (the back end has eyes)."""
        return self.backend is not None and self.backend.eyes is not None

    def cell_corners(self) -> dict[int, dict[str, np.ndarray]]:
        """Cell (1..9) -> ``tl|tr|br|bl`` -> point (3,), metres: as last seen by the eyes
        (looking first when it is the robot's turn and it has not looked yet), else the known
        geometry (no cameras)."""
        sight = self.look()
        if sight is None:
            return {cell: cell_corners(self.spec, cell) for cell in range(1, 10)}
        return sight["corners"]

    def look(self) -> dict[str, Any] | None:
        """The latest sighting of the board; a new one when it is the robot's turn and the eyes
        have not seen the board since the last move (or never).  None without cameras."""
        if not self.sees:
            return None
        last = self.sightings[-1] if self.sightings else None
        if last is not None and (last["moves_before"] == len(self.moves) or self.to_move() != ROBOT):
            return last
        from .vision import corner_error, look_at_board

        clock = time.perf_counter()
        sight = look_at_board(self.backend, self.spec.surface_z, self.board, self.lift_point(),
                              self.aside_point())
        true = {cell: cell_corners(self.spec, cell) for cell in range(1, 10)}
        entry = {"moves_before": len(self.moves), "board": sight.board, "corners": sight.corners,
                 "views": sight.views, "arm": sight.arm, "corner_error_m": corner_error(sight, true),
                 "seconds": time.perf_counter() - clock}
        self.sightings.append(entry)
        return entry

    def seen_board(self) -> ttt.Board:
        """The board minimax plays on: read by the eyes (equal to the record, or
        :meth:`look` raised), else the game's memory (no cameras)."""
        sight = self.look()
        return self.board if sight is None else tuple(sight["board"])

    def query(self, name: str, *args: Any) -> Any:
        if name == "game_over":
            return ttt.game_over(self.board)
        if name == "robot_to_move":
            return self.to_move() == ROBOT
        if name == "opponent_to_move":
            return self.to_move() == OPPONENT
        if name == "best_move":
            return f"board.cell{self.best_move()}"
        if name == "best_cell":
            return self.best_move()
        if name == "last_move":
            if not self.marks:
                raise HilaRuntimeError("the robot has not drawn a mark yet: there is no last move")
            return f"board.cell{self.marks[-1]['cell']}"
        if name == "winner":
            return self.result()
        if name == "marks":
            return 9 - self.board.count(ttt.EMPTY)
        if name == "free":
            if len(args) != 1:
                raise InputError(f"query 'free' takes one cell number, got {len(args)} arguments")
            cell = args[0]
            if isinstance(cell, float) and cell.is_integer():
                cell = int(cell)
            if isinstance(cell, bool) or not isinstance(cell, int) or not 1 <= cell <= 9:
                raise InputError(f"query 'free' expects a cell 1..9, got {cell!r}")
            return self.board[cell - 1] == ttt.EMPTY
        from . import WORLD

        raise UnknownNameError("question", name, WORLD.questions, owner="the tictactoe world")

    def wait(self, event: str, *args: Any) -> Any:
        if event != "opponent_moved":
            from . import WORLD

            raise UnknownNameError("event", event, WORLD.events, owner="the tictactoe world")
        if ttt.game_over(self.board):
            return None
        if self.to_move() != OPPONENT:
            raise HilaRuntimeError("waiting for the opponent, but it is the robot's turn")
        cell = int(self.opponent.choose(self.board))
        self.board = ttt.play(self.board, cell, ttt.CROSS)
        strokes = cross_strokes(self.spec, cell, self.rng)
        if self.backend is not None and self.backend.ink is not None:
            for stroke in strokes:
                self.backend.ink.ink_polyline(stroke)
        self.crosses.append(strokes)
        self._record_move(OPPONENT, cell)
        return cell

    def notify(self, event: str, **data: Any) -> None:
        if event != "state_done":
            return
        executed = data.get("executed")
        planned = data.get("path")
        entry = {
            "state": str(data.get("state", "")),
            "pen_down": bool(data.get("pen_down", False)),
            "planned": None if planned is None else np.asarray(planned, dtype=float),
            "executed": None if executed is None else np.asarray(executed, dtype=float),
        }
        self.states.append(entry)
        if entry["pen_down"]:
            self._record_circle(entry, data.get("template"))

    # -- game logic --------------------------------------------------------------------------
    def to_move(self) -> str | None:
        """``"robot"``, ``"opponent"``, or None when the game is over."""
        if ttt.game_over(self.board):
            return None
        placed = 9 - self.board.count(ttt.EMPTY)
        robot_first = self.first == ROBOT
        return ROBOT if (placed % 2 == 0) == robot_first else OPPONENT

    def lift_point(self) -> np.ndarray:
        """Straight above the pen at the park height, shape (3,): the hand's start of a reach.

        After a circle the pen is low over the paper; a reach warped from there would squash
        the demonstrated approach flat onto the paper, so each reach starts from this point
        (the back end lifts the pen straight up to it).  At the start it is :attr:`park`.
        """
        here = self.park if self.backend is None else np.asarray(self.backend.hand_position(), dtype=float)
        return np.array([here[0], here[1], max(float(here[2]), float(self.park[2]))])

    def aside_point(self) -> np.ndarray:
        """Where the pen goes so that the arm is out of the eyes' view of the board, shape (3,):
        beyond the grid's near-right corner (the arm's side), at the park height."""
        half = self.spec.grid_size / 2
        point = self.spec.grid_to_world(half + ASIDE_MARGIN, -half)
        point[2] = self.park[2]
        return point

    def best_move(self) -> int:
        """The robot's minimax move on the board it sees (centre first among equals)."""
        if ttt.game_over(self.board):
            raise HilaRuntimeError("the game is over: the robot has no move to make")
        return ttt.best_move(self.seen_board(), ttt.CIRCLE)

    def result(self) -> str | None:
        """``"robot"``, ``"opponent"``, ``"draw"``, or None while the game goes on."""
        w = ttt.winner(self.board)
        if w == ttt.CIRCLE:
            return ROBOT
        if w == ttt.CROSS:
            return OPPONENT
        return "draw" if ttt.EMPTY not in self.board else None

    def _record_circle(self, entry: dict[str, Any], template=None) -> None:
        from .marks import mark_correlation, outside_cell, tracking_error  # metrics: lazy

        drawn = entry["executed"] if entry["executed"] is not None else entry["planned"]
        if drawn is None or len(drawn) == 0:
            raise HilaRuntimeError("the robot drew, but the back end reported no path",
                                   state=entry["state"])
        touching = on_paper(drawn, self.spec.surface_z)
        ink = touching if len(touching) >= 3 else drawn
        cell = cell_at(self.spec, np.median(ink, axis=0))
        if cell is None:
            raise HilaRuntimeError("the robot drew its circle outside the grid", state=entry["state"])
        if self.to_move() != ROBOT:
            raise HilaRuntimeError(f"the robot drew in cell {cell}, but it is not its turn",
                                   state=entry["state"])
        if self.board[cell - 1] != ttt.EMPTY:
            raise HilaRuntimeError(f"the robot drew in cell {cell}, which is taken", state=entry["state"])
        intended = self.best_move()
        demo = None if template is None else np.asarray(template.path, dtype=float)
        demo_circle = None if demo is None else on_paper(demo, float(demo[:, 2].min()))
        planned = entry["planned"]
        planned_circle = None if planned is None else on_paper(planned, self.spec.surface_z)

        def r_of(circle):
            ok = demo_circle is not None and circle is not None and len(circle) >= 4 and len(demo_circle) >= 4
            return mark_correlation(circle, demo_circle) if ok else None

        mark = {
            "cell": cell,
            "intended_cell": intended,
            "state": entry["state"],
            "planned": planned,
            "executed": drawn,
            "contact_points": int(len(touching)),
            "outside_cell_m": outside_cell(self.spec, cell, ink),
            "r": r_of(touching),
            "r_planned": r_of(planned_circle),
        }
        if entry["planned"] is not None and entry["executed"] is not None:
            err = tracking_error(entry["planned"], entry["executed"], prefix=True)
            mark["tracking_median_m"] = float(np.median(err))
            mark["tracking_max_m"] = float(err.max())
        self.marks.append(mark)
        self.board = ttt.play(self.board, cell, ttt.CIRCLE)
        self._record_move(ROBOT, cell)

    def _record_move(self, who: str, cell: int) -> None:
        mark = ttt.CIRCLE if who == ROBOT else ttt.CROSS
        self.moves.append({"player": who, "mark": mark, "cell": cell,
                           "t": round(time.perf_counter() - self.t0, 3)})
        self._print(f"\n{who} ({mark}) plays cell {cell}")
        self._print(ttt.render(self.board))

    # -- the end -----------------------------------------------------------------------------
    def finish(self, trace=None, *, fsm=None) -> dict[str, Any]:
        """Print the result and write the output folder; returns the report as a dict."""
        from .report import build_report, write_outputs

        if fsm is not None:
            self.fsm = fsm
        result = self.result()
        text = {ROBOT: "the robot wins", OPPONENT: "the opponent wins", "draw": "a draw",
                None: "unfinished"}[result]
        report = build_report(self, trace)
        rs = [m["r"] for m in self.marks if m["r"] is not None]
        self._print(f"\nresult: {text}" + (f"; per-mark R min {min(rs):.3f}" if rs else ""))
        if self.write_report:
            folder = write_outputs(self, report)
            report["out"] = str(folder)
            self._print(f"outputs written to {folder}")
        return report


def make_world(options, settings) -> TicTacToeWorld:
    """Plug-in factory (:data:`hila_lang.worlds.tictactoe.WORLD`)."""
    return TicTacToeWorld(options, settings)
