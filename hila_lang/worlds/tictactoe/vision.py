"""The robot reads the tic-tac-toe board through its own eye cameras (issue 6, item 5).

Before each of its moves the robot looks at the board and reads, with
:func:`hila_lang.worlds.tictactoe.reading.read_board` (OpenCV), where the grid's cells are (their
corners become the ICPs the program binds) and which cells hold a cross or a circle (the board
minimax plays on).  Nothing of the game's memory goes into the reading; the game's own record
is used only to check it (and to decide to look again).

Views, in order, each taken only when the ones before leave a doubt (the head re-aims at the
grid centre for every image, so "looking" is rendering an eye camera aimed at the board):

1. ``left eye``: the left eye, the arm where it is;
2. ``left eye (arm lifted)``: the pen goes straight up to ``lift`` -- the point the next reach
   starts from anyway, so the arm makes no extra journey -- and the left eye looks again;
3. ``left eye (arm aside)``: the last resort: the pen goes to ``aside``, beyond the grid on the
   arm's side, and the left eye looks again;
4. ``right eye (arm aside)``: the right eye, for cells the left eye still sees hidden.

After going aside the pen comes back to ``lift``, so the program's next reach starts where it
would have.  The right eye is not tried with the arm over the board: the arm comes from the
robot's right and hides the same cells from the right eye (measured on seeds 0, 2, 3 and 4: in
each of the four turns where the left eye was in doubt, the right eye was too).  Each left-eye
view starts afresh (the cells it sees unhidden); a right-eye view fills in cells it left hidden.

A view is in doubt when some cell is hidden (more than 20 % neither paper nor ink) or when what
it reads differs from the game's record (a shaded arm can look like a stroke without hiding 20 %
of a cell).  When the last view still leaves a hidden cell or a cell that differs from the
record, :func:`look_at_board` raises :class:`~hila_lang.errors.HilaRuntimeError` naming the
cells: the game never goes on on a board it did not see.

Measured over 20 whole PyBullet games (seeds 0-19, ``bench/game.py``'s series): the cell corners
are within 0.4 mm of the true ones; the left eye alone settles most turns; the pen is lifted in
about one turn per game (when, low over the far-right cells after a circle, it hides or darkens
one); the arm went aside in 2 turns of 20 games (the park place above the grid hid cell 3 at the
first move).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ...errors import HilaRuntimeError, InputError

#: the views tried in order: (name, eye, where the arm is: "still", "lifted" or "aside")
VIEWS = (("left eye", "left", "still"), ("left eye (arm lifted)", "left", "lifted"),
         ("left eye (arm aside)", "left", "aside"), ("right eye (arm aside)", "right", "aside"))
#: the pen is lifted only when it is more than this below the lift point, metres
LIFT_TOLERANCE = 0.005
_NAMES = {"": "empty", "O": "a circle (O)", "X": "a cross (X)"}


@dataclass
class BoardSight:
    """What the robot's eyes made of the board before one of its moves.

    Attributes
    ----------
    board : tuple of 9 str
        Marks read, cells 1..9, each in {"", "O", "X"}.
    corners : dict[int, dict[str, ndarray]]
        Cell (1..9) -> ``tl|tr|br|bl`` -> point (3,), world frame, metres (on the paper).
    views : list of dict
        Per image looked at: ``view`` (name), ``occluded`` (cells), ``marks`` or ``error``.
    arm : str
        Where the arm went to see the board: "still" (nowhere), "lifted" or "aside" (and back).
    """

    board: tuple[str, ...]
    corners: dict[int, dict[str, np.ndarray]]
    views: list[dict[str, Any]] = field(default_factory=list)
    arm: str = "still"


def look_at_board(backend, surface_z: float, record: Sequence[str], lift: np.ndarray | None = None,
                  aside: np.ndarray | None = None, *, read: Callable | None = None) -> BoardSight:
    """Read the board through ``backend``'s eye cameras (see the module docstring).

    Parameters
    ----------
    backend
        A :class:`~hila_lang.plugins.protocols.Backend` with eyes (``backend.eyes``); it moves
        the arm with ``move`` when ``lift`` is given.
    surface_z : float
        World z of the paper, metres.
    record : sequence of 9 str
        The game's own board, to check the reading against.
    lift : ndarray, shape (3,), optional
        Where the pen goes straight up to (the next reach's start) and comes back to after
        going aside; None: the arm does not move.
    aside : ndarray, shape (3,), optional
        A pen position with the arm out of the eyes' view of the board; None: not used.
    read : callable, optional
        ``read(image, surface_z) -> BoardReading``; default
        :func:`hila_lang.worlds.tictactoe.reading.read_board`.

    Raises
    ------
    HilaRuntimeError
        No view found the grid, or the last view still leaves cells hidden or different from
        the record (the message names them).
    """
    if read is None:
        from .reading import read_board

        read = read_board
    record = tuple(record)
    marks: list[str | None] = [None] * 9
    corners = None
    fewest_hidden = 10
    views: list[dict[str, Any]] = []
    arm = "still"
    can_move = lift is not None
    try:
        for name, eye, where in VIEWS:
            if where != arm:
                if not can_move or (where == "aside" and aside is None):
                    break
                moved = _move_arm(backend, np.asarray(lift if where == "lifted" else aside, dtype=float),
                                  straight_up=where == "lifted")
                arm = where
                if not moved:  # the pen was already that high: the same view again would not help
                    continue
            image = backend.eyes.camera_image(eye)
            try:
                reading = read(image, surface_z)
            except InputError as exc:
                views.append({"view": name, "error": str(exc).splitlines()[0]})
                continue
            hidden = sorted(int(c) for c in reading.occluded)
            views.append({"view": name, "occluded": hidden, "marks": list(reading.marks)})
            if len(hidden) < fewest_hidden or (eye == "left" and len(hidden) == fewest_hidden):
                corners, fewest_hidden = reading.corners, len(hidden)
            first_of_arm = eye == "left"  # a left-eye view after the arm moved overrides the views before
            for cell in range(1, 10):
                if cell not in hidden and (marks[cell - 1] is None or first_of_arm):
                    marks[cell - 1] = reading.marks[cell - 1]
                elif cell in hidden and first_of_arm:
                    marks[cell - 1] = None
            if None not in marks and tuple(marks) == record:
                return BoardSight(tuple(marks), corners, views, arm)
    finally:
        if arm == "aside":
            _move_arm(backend, np.asarray(lift, dtype=float), straight_up=False)
    if corners is None:
        raise HilaRuntimeError(
            "the robot's eyes did not find the board: "
            + "; ".join(f"{v['view']}: {v['error']}" for v in views),
            hint="is the grid in the eye cameras' view?")
    hidden = [c for c in range(1, 10) if marks[c - 1] is None]
    wrong = [c for c in range(1, 10) if marks[c - 1] is not None and marks[c - 1] != record[c - 1]]
    parts = [f"cell {c} hidden in every view" for c in hidden]
    parts += [f"cell {c} seen {_NAMES[marks[c - 1]]}, the game's record says {_NAMES[record[c - 1]]}"
              for c in wrong]
    raise HilaRuntimeError(
        "the board the robot sees differs from the game's record: " + "; ".join(parts)
        + f" (looked {len(views)} times: " + "; ".join(v["view"] for v in views) + ")",
        hint="a misread mark or a mark that was not inked; the robot does not play on a board it did not see")


def _move_arm(backend, target: np.ndarray, *, straight_up: bool) -> bool:
    """Move the pen to ``target`` (3,); ``straight_up``: only up to its height, and only when
    the pen is more than :data:`LIFT_TOLERANCE` lower.  True when the arm moved."""
    here = np.asarray(backend.hand_position(), dtype=float)
    if straight_up:
        if here[2] >= target[2] - LIFT_TOLERANCE:
            return False
        target = np.array([here[0], here[1], target[2]])
    backend.move(target[None], label="look")
    return True


def corner_error(sight: BoardSight, true_corners: dict[int, dict[str, np.ndarray]]) -> float:
    """Largest distance (metres) between perceived and true cell corners."""
    return max(float(np.linalg.norm(sight.corners[c][n] - true_corners[c][n]))
               for c in true_corners for n in true_corners[c])


# --------------------------------------------------------------------------- learning the demonstration

#: a path point within this height of the paper counts as touching it (demonstrated cell), metres
CONTACT_TOLERANCE = 0.004


def demonstration_icps(view, frames: int, path: np.ndarray, surface_z: float, names=None):
    """The ICP reader of the circle demonstration (for :func:`hila_lang.perception.learn.perceive`).

    The grid is read in each eye's undistorted image (:func:`.reading.read_board`; the first
    frame, else the last or the middle one when the hand hides the grid); the demonstrated cell
    is the one the pen touches (path points within :data:`CONTACT_TOLERANCE` of the paper), its
    corners (left and right averaged) become ``tl``, ``tr``, ``br``, ``bl``, and ``hand`` is the
    first triangulated point (names as :mod:`.demonstration` uses them).
    """
    from ...perception.learn import IcpReading, frame_name
    from .reading import read_board

    names = names or {}
    readings = []
    for eye in ("left", "right"):
        problems = []
        for i in dict.fromkeys([0, frames - 1, frames // 2]):  # the hand may hide the grid
            try:
                readings.append(read_board(view(eye, i), surface_z))
                break
            except InputError as exc:
                problems.append(f"{frame_name(names.get(eye), i)}: {exc.message}")
        else:
            raise InputError(f"no grid found in the {eye} frames tried ({'; '.join(problems)})",
                             hint="the ICPs (cell corners) are read from the first, last or middle frame")
    cell = _touched_cell(path, readings[0], surface_z)
    icps = {name: (readings[0].corners[cell][name] + readings[1].corners[cell][name]) / 2
            for name in ("tl", "tr", "br", "bl")}
    icps["hand"] = path[0].copy()
    return IcpReading(icps, f"ICPs tl, tr, br, bl = corners of cell {cell} read from the images, "
                            f"hand = the first triangulated point.", {"cell": cell})


def _touched_cell(path: np.ndarray, reading, surface_z: float) -> int:
    """The cell (1..9) holding most path points within CONTACT_TOLERANCE of the paper."""
    low = path[np.abs(path[:, 2] - surface_z) < CONTACT_TOLERANCE]
    if len(low) == 0:
        raise InputError(f"the pen never touches the paper (lowest point {path[:, 2].min() - surface_z:+.3f} m "
                         f"from the surface): cannot tell which cell was demonstrated")
    rel = low[:, :2] - reading.center[:2]
    right = rel @ reading.right[:2] / reading.cell_size
    far = rel @ reading.far[:2] / reading.cell_size
    col = np.floor(right + 1.5).astype(int)
    row = np.floor(1.5 - far).astype(int)
    inside = (col >= 0) & (col < 3) & (row >= 0) & (row < 3)
    if not inside.any():
        raise InputError("the pen touches the paper only outside the grid: cannot tell the demonstrated cell")
    cells = row[inside] * 3 + col[inside] + 1
    return int(np.bincount(cells).argmax())
