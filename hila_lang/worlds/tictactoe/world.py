"""The ``tictactoe`` world that ``programs/game.hila`` runs in (the paper's Experiment B).

The iCub plays its own mark (``O`` on the board: whatever its program draws -- the circle of
``primitives/circle.yaml`` in the paper's experiment, or a person's triangle) on
:meth:`Grid.game` -- a grid 20 % smaller than the demonstration's, rotated and 0.20 m higher --
against an opponent who plays crosses (``X``).  The world is told the program's pen-down
sub-templates before it runs (``notify("program", marks=...)``): the robot reads its own
marks on the paper by them (:mod:`.ownmark`); ``hila check`` refuses a mark too like the cross
(:func:`check_mark`).

Two sides, kept apart.  The robot's side is a :class:`~.player.Player`: it decides from what
the robot's eyes see (:mod:`.vision`) and what it remembers, and has no handle on the game's
record; the record is sealed while the world answers the robot's questions and names its
points (reading it then raises :class:`~.referee.SealedRecordError`).  The :class:`~.referee.Referee` keeps the record, plays the opponent on the real board,
perturbs the scene between moves and scores after the fact (``report.json``: ``vision``, with
every misread).  Every question the program asks is answered by the robot's side; the referee
acts only when the robot waits for the opponent and after the robot has drawn.

Its scene points, questions (``ask``), events (``wait``) and settings are declared once, with their
arguments and docs, in :data:`hila_lang.worlds.tictactoe.WORLD` (``hila show world tictactoe``
prints them); :meth:`TicTacToeWorld.query` and :meth:`TicTacToeWorld.wait` answer through that
table (the ``ask_*`` and ``wait_*`` methods), and ``hila check`` checks a program against it.
Every question is answered from the robot's own view of the board; ``best_move`` and
``last_move`` are point groups (``"board.cell5"``), so ``c.*`` binds the ICPs ``tl``, ``tr``,
``br``, ``bl`` to the cell's corners.  ``wait opponent_moved``: the opponent plays a cell on the
real board, its cross is inked on the paper, the scene is perturbed (settings below), and the
cell is returned (the opponent announces it; a robot with eyes still reads the board itself).
``notify("state_done", pen_down=True, executed=TRACE, ...)``: the referee records the robot's
circle in the cell where the pen actually drew.  The board is printed after every move.

Seeing the board.  With a back end that has eyes (``backend.eyes``: PyBullet) the robot looks
before every decision that follows a move (:func:`.vision.look_at_board`) and, while unsure,
looks again -- the other eye, the arm lifted, the arm aside, the gaze moved.  With the dry back
end (no cameras) it plays blind: the corners are the board's layout and the board is the moves
it made and the moves the opponent announced.

Settings (``--set key=value``, declared in :mod:`hila_lang.worlds.tictactoe`):
``opponent=random|minimax|human`` (default minimax; ``--opponent`` is an alias),
``first=robot|opponent`` (default robot, as in the paper), ``report=yes|no`` (write the output
folder, default yes), and the perturbations, seeded by ``--seed``: ``board.bump=D`` (metres),
``light=F``, ``crosses=neat|sloppy`` (:mod:`.referee`), and while the robot draws
``board.slide=D``, ``board.turn=DEG``, ``board.jump=D`` (:mod:`hila_lang.sim.motion`: a program that tracks
its cell, ``track c``, follows the sheet through its eyes, :mod:`.tracking`); the back end's
``eyes.noise=SIGMA`` adds sensor noise.  Each circle is compared with the demonstration it was warped from: the
path of the program's pen-down sub-template.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ...core.errors import HilaRuntimeError, InputError, UnknownNameError
from ...plugins.snapshots import AttributeSnapshots
from ...sim.surface import Scene
from . import rules as ttt, WORLD
from .board import Grid
from .opponents import make_opponent
from .player import Hand, OPPONENT, Player, ROBOT
from .referee import Referee
from .report import build_report, write_outputs
from .tracking import TicTacToeTracking

#: park height above the paper, metres (low, high)
PARK_HEIGHT = (0.08, 0.13)
#: the robot waits for an opponent who has nothing to play at most this many times in a row
IDLE_WAITS = 3
#: the game stops after this many circles drawn out of turn or over a mark (the referee's fouls)
MAX_FOULS = 3


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
        Parsed (see :data:`hila_lang.worlds.tictactoe.WORLD`).

    Attributes
    ----------
    player : Player
        The robot's side.
    referee : Referee
        The record, the opponent's moves, the perturbations and the scores.
    """

    def __init__(self, options, settings: dict[str, Any] | None = None) -> None:
        self.t0 = time.perf_counter()
        self.options = options
        self.seed = int(options.seed)
        self.settings = {**WORLD.parse({}), **(settings or {})}
        layout = Grid.game()
        self.scene = Scene(surface=layout.paper())
        self.first = self.settings["first"]
        self.write_report = self.settings["report"]
        #: the output folder, made and proved writable now: a game is never played to be lost
        self.outputs = None
        if self.write_report:
            # lazy: only this branch needs it
            from .report import output_folder

            self.outputs = output_folder(options.out, self.seed)
        self.rng = np.random.default_rng([self.seed, 5])
        self.park = park_position(layout, self.rng)
        self.opponent = make_opponent(self.settings["opponent"], self.seed, options.stdin, options.stdout)
        self.stdout = options.stdout
        self.referee = Referee(layout, self.first, self.seed, bump=self.settings["board.bump"],
                               light=self.settings["light"], sloppy=self.settings["crosses"] == "sloppy",
                               slide=self.settings["board.slide"], turn=self.settings["board.turn"],
                               jump=self.settings["board.jump"])
        self.player = Player(self.first, self.park, layout=layout)
        self.states: list[dict[str, Any]] = []

        #: following the sheet while the robot draws (``track``), and moving it (``board.slide``)
        self.tracking = TicTacToeTracking(self)
        self.backend = None
        self.fsm = None
        self._scored = 0
        self._told_unclear: list = []
        self._idle = 0
        #: the REPL's ``back``: the game as it was -- the referee's record, sheet pose, generator
        #: and scores, the robot's own memory (its moves, table estimate, what it last chose), the
        #: opponent's and the scene's generators; lists that only grow are cut back
        self.snapshots = AttributeSnapshots(
            self,
            ("rng", "opponent._rng", "_scored", "_idle", "referee.grid", "referee.rng", "referee.record._board",
             "referee.stray", "referee.motion.rng",
             "player.table", "player.own", "player.choice", "player._blind_board", "player._since", "player._stale",
             "player.glanced"),
            append_only=("states", "referee.record._moves", "referee.marks", "referee.crosses", "referee.looks",
                         "referee.misreads", "referee.unclear", "_told_unclear", "referee.fouls",
                         "referee.perturbations", "player.sightings", "referee.motion.moves", "player.glances"))

    # -- the referee's view, for reports and tests -------------------------------------------
    @property
    def spec(self) -> Grid:
        """Where the sheet and its grid really are now (moved by ``board.bump``)."""
        return self.referee.grid

    @property
    def board(self) -> ttt.Board:
        """The real board (the referee's record)."""
        return self.referee.record.board

    @property
    def moves(self) -> list[dict[str, Any]]:
        return self.referee.record.moves

    @property
    def marks(self) -> list[dict[str, Any]]:
        """The robot's circles as the referee scored them."""
        return self.referee.marks

    @property
    def crosses(self) -> list[list[np.ndarray]]:
        return self.referee.crosses

    @property
    def sightings(self) -> list[dict[str, Any]]:
        """The robot's looks (:attr:`.player.Player.sightings`)."""
        return self.player.sightings

    @property
    def sees(self) -> bool:
        """Whether the board is read through eye cameras (the back end has eyes)."""
        return self.player.sees

    def _print(self, text: str = "") -> None:
        print(text, file=self.stdout, flush=True)

    # -- plug-in hooks -----------------------------------------------------------------------
    def attach(self, backend) -> None:
        """Park the arm at :attr:`park` (no drawing), give the robot's side its eyes and arm,
        and the referee the paper and the lights."""
        needs = [name for name, on in (("board.bump", self.referee.bump > 0), ("light", self.referee.light != 1.0))
                 if on]
        missing = [cap for cap, on in (("eyes", True), ("ink", "board.bump" in needs),
                                       ("lighting", "light" in needs)) if getattr(backend, cap) is None]
        if needs and missing:
            raise InputError(f"--set {' and '.join(needs)} changes the scene between moves, which only a back end "
                             f"with eyes, a paper and lights can show; back end {backend.name!r} has no "
                             f"{', '.join(missing)}", hint="use --backend pybullet")
        motion = self.referee.motion
        moving = [f"board.{k}" for k in ("slide", "turn", "jump") if getattr(motion, k) > 0]
        missing = [cap for cap in ("eyes", "ink", "streaming") if getattr(backend, cap, None) is None]
        if moving and missing:
            raise InputError(f"--set {' and '.join(moving)} moves the sheet while the robot draws, which only a back "
                             f"end with eyes, a paper and a streaming arm can show; back end {backend.name!r} has no "
                             f"{', '.join(missing)}", hint="use --backend pybullet")
        self.backend = backend
        self.referee.backend = backend
        backend.reset_hand(self.park)
        hand = Hand(backend.hand_position, lambda path: backend.move(path, label="look"))
        # the layout only for a robot that plays blind: one with eyes knows the board from its sightings
        robot = getattr(backend, "robot", None)  # the robot's spec (hila_lang.robot.spec), if the back end has one
        self.player = Player(self.first, self.park, eyes=backend.eyes, hand=hand,
                             table_prior=None if robot is None else robot.table_prior,
                             layout=self.referee.layout if backend.eyes is None else None)
        self._print(f"tic-tac-toe: the robot plays its own mark (O on the board), the opponent "
                    f"({self.opponent.name}) plays X; {self.first} starts")
        self._print(ttt.render(self.board))

    # -- World protocol: the robot's side (the record is sealed meanwhile) -------------------
    def points(self) -> dict[str, np.ndarray]:
        with self.referee.record.sealed():
            return self._points()

    def query(self, name: str, *args: Any) -> Any:
        with self.referee.record.sealed():
            return self._answer(name, *args)

    def _points(self) -> dict[str, np.ndarray]:
        corners = self.player.corners()
        pts: dict[str, np.ndarray] = {"arm.park": self.park.copy(), "arm.lift": self.player.lift_point()}
        for cell in range(1, 10):
            for name, p in corners[cell].items():
                pts[f"board.cell{cell}.{name}"] = np.asarray(p, dtype=float).copy()
        if self.player.to_move() == ROBOT:
            for name, p in corners[self.player.best_move()].items():
                pts[f"board.move.{name}"] = np.asarray(p, dtype=float).copy()
        return pts

    def _answer(self, name: str, *args: Any) -> Any:
        return WORLD.questions.answer(self, name, args, "the tictactoe world")

    # the questions, as declared in :data:`hila_lang.worlds.tictactoe.WORLD` (name, arguments, doc)
    def ask_game_over(self) -> bool:
        return self.player.game_over()

    def ask_robot_to_move(self) -> bool:
        return self.player.to_move() == ROBOT

    def ask_opponent_to_move(self) -> bool:
        return self.player.to_move() == OPPONENT

    def ask_best_move(self) -> str:
        return f"board.cell{self.player.best_move()}"

    def ask_best_cell(self) -> int:
        return self.player.best_move()

    def ask_last_move(self) -> str:
        return f"board.cell{self.player.last_move()}"

    def ask_winner(self) -> str | None:
        w = ttt.winner(self.player.board())
        return {ttt.CIRCLE: ROBOT, ttt.CROSS: OPPONENT}.get(w, "draw" if self.player.game_over() else None)

    def ask_marks(self) -> int:
        return 9 - self.player.board().count(ttt.EMPTY)

    def ask_free(self, cell: Any) -> bool:
        if isinstance(cell, float) and cell.is_integer():
            cell = int(cell)
        if isinstance(cell, bool) or not isinstance(cell, int) or not 1 <= cell <= 9:
            raise InputError(f"query 'free' expects a cell 1..9, got {cell!r}")
        return self.player.board()[cell - 1] == ttt.EMPTY

    # -- World protocol: the referee's side ---------------------------------------------------
    def wait(self, event: str, *args: Any) -> Any:
        return WORLD.events.answer(self, event, args, "the tictactoe world")

    def wait_opponent_moved(self) -> Any:
        """The opponent plays on the real board (the referee's side)."""
        self._score()
        turn = self.referee.to_move()
        if turn is None:
            self._idle += 1
            if self._idle >= IDLE_WAITS:
                raise HilaRuntimeError(f"the robot has waited {self._idle} times for an opponent who has no move: "
                                       f"the game is over on the paper ({self._seen_versus_real()})")
            return None
        if turn != OPPONENT:
            raise HilaRuntimeError("waiting for the opponent, but it is the robot's turn"
                                   + (f" ({self._seen_versus_real()})" if self.player.sightings else ""))
        self._idle = 0
        cell = self.referee.opponent_moves(self.opponent, time.perf_counter() - self.t0)
        self._print(f"\n{OPPONENT} ({ttt.CROSS}) plays cell {cell}")
        self._print(ttt.render(self.board))
        event_ = self.referee.perturb()
        if event_ is not None:
            self._print("the scene changes: " + "; ".join(
                f"the sheet is pushed {e['shift_mm']:.0f} mm and turned {e['turn_deg']:+.1f} deg from where it was laid"
                if k == "board" else f"the light changes to {e['level']:.2f}"
                for k, e in event_.items() if k != "after_move"))
        self.player.opponent_moved(cell)
        return cell

    @property
    def seen_board(self) -> ttt.Board:
        """The board as the robot last read it (its latest sighting; blind: as it knows it), cells
        1..9 in {"", "O", "X", "?"}: what a view of the robot's side shows (the report's
        ``vision`` has every look)."""
        if self.player.sightings:
            return tuple(self.player.sightings[-1]["board"])
        return tuple(self.player._blind_board)

    def notify(self, event: str, **data: Any) -> None:
        if event == "program":  # the pen-down sub-templates the program draws with: the robot's own mark
            # lazy: only this branch needs it
            from .ownmark import OwnMark

            self.player.mark = OwnMark.from_templates(data.get("marks") or {})
            if self.player.mark is not None:
                self._print(f"the robot's mark: what {', '.join(self.player.mark.names)} inks (O on the board)")
            return
        if event != "state_done":
            return
        executed = data.get("executed")
        planned = data.get("path")
        entry = {
            "state": str(data.get("state", "")),
            "pen_down": bool(data.get("pen_down", False)),
            "planned": None if planned is None else np.asarray(planned, dtype=float),
            "executed": None if executed is None else np.asarray(executed, dtype=float),
            "sheet": self.referee.grid,  # where the sheet was while this state ran (at its end)
            # where it was at each step of a stroke it moved during (:mod:`hila_lang.sim.motion`)
            "during": list(self.referee.motion.during) if data.get("pen_down") else None,
            "replans": [{"t_s": round(r.t, 3), "moved_mm": round(1000 * r.moved, 2), "icp": r.which,
                         "from_point": r.stamp, "blend_mm": round(1000 * r.blend, 2), "lifted": r.lifted}
                        for r in data.get("replans") or ()],
        }
        self.states.append(entry)
        if entry["pen_down"]:
            self._score()
            fouls = len(self.referee.fouls)
            mark = self.referee.score_circle(entry, data.get("template"), self.player.choice,
                                             time.perf_counter() - self.t0)
            mark["replans"] = entry["replans"]
            self.player.drew(entry["planned"])  # what it commanded, not the simulator's pen tip
            self._print(f"\n{ROBOT} ({ttt.CIRCLE}) plays cell {mark['cell']}")
            for foul in self.referee.fouls[fouls:]:
                self._print(f"referee: the robot's circle in cell {mark['cell']} is {foul['foul']}")
            self._print(ttt.render(self.board))
            if len(self.referee.fouls) >= MAX_FOULS:
                raise HilaRuntimeError(f"the robot has drawn {len(self.referee.fouls)} circles where it may not: the "
                                       f"game cannot go on ({self._seen_versus_real()})", state=entry["state"])

    def _score(self) -> None:
        """The referee scores the sightings made since it last did (the truth has not changed
        since: it changes only when the opponent moves or the robot draws, after this)."""
        for sight in self.player.sightings[self._scored:]:
            for m in self.referee.score_sighting(sight):
                self._print(f"referee: at look {m['look']} the robot saw cell {m['cell']} {ttt.NAMES[m['seen']]}, "
                            f"it holds {ttt.NAMES[m['true']]}")
            for u in self.referee.unclear[len(self._told_unclear):]:
                self._told_unclear.append(u)
                self._print(f"referee: at look {u['look']} the robot could not tell the ink in cell {u['cell']} "
                            f"(it holds {ttt.NAMES[u['true']]})")
        self._scored = len(self.player.sightings)

    def _seen_versus_real(self) -> str:
        seen = self.player.sightings[-1]["board"] if self.player.sightings else self.player.board()
        return "the robot sees " + " ".join(m or "." for m in seen) + "; the paper holds " + \
            " ".join(m or "." for m in self.referee.paper_marks())

    # -- the end -----------------------------------------------------------------------------
    def result(self) -> str | None:
        """``"robot"``, ``"opponent"``, ``"draw"``, or None while the game goes on (the real board)."""
        return self.referee.result()

    def _why_unfinished(self, result) -> str:
        """Why a game reads unfinished when the referee counted fouls: which circles did not count."""
        fouls = self.referee.fouls
        if result is not None or not fouls:
            return ""
        told = []
        for f in fouls:
            why = ("the robot drew twice without the opponent playing in between" if f["foul"] == "drawn out of turn"
                   else "the cell was already taken")
            told.append(f"the circle in cell {f['cell']} was {f['foul']} ({why})")
        return (f" -- the referee did not count {len(fouls)} circle(s): " + "; ".join(told)
                + "; the game needs a move by each side in turn")

    def finish(self, trace=None, *, fsm=None) -> dict[str, Any]:
        """Print the result and write the output folder; returns the report as a dict."""
        if fsm is not None:
            self.fsm = fsm
        self._score()
        result = self.result()
        text = RESULT_WORDS[result]
        report = build_report(self, trace)
        rs = [m["r"] for m in self.marks if m["r"] is not None]
        vision = report["vision"]
        seen = "" if vision["board_read_by"] != "vision" else \
            f"; {vision['looks']} looks, {len(vision['misreads'])} misread cell(s)"
        self._print(f"\nresult: {text}{self._why_unfinished(result)}" + (f"; per-mark R min {min(rs):.3f}" if rs else "")
                    + seen)
        if self.write_report:
            folder = write_outputs(self, report)
            report["out"] = str(folder)
            self._print(f"outputs written to {folder}")
        return report


#: the game's result (:meth:`TicTacToeWorld.result`) in words: the last line of a run, the studio's outcome
RESULT_WORDS = {ROBOT: "the robot wins", OPPONENT: "the opponent wins", "draw": "a draw", None: "unfinished"}


def make_world(options, settings) -> TicTacToeWorld:
    """Plug-in factory (:data:`hila_lang.worlds.tictactoe.WORLD`)."""
    return TicTacToeWorld(options, settings)
