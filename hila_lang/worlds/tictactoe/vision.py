"""The robot reads the tic-tac-toe board through its own eyes, and decides when to look again.

Nothing of the game's record or of the simulator's truth goes in: :func:`look_at_board` gets
the robot's eyes (images with their own calibration and poses from the joint angles), its arm,
its estimate of the table (:class:`Table`) and what it remembers (:class:`Memory`: the board
it saw last and how many marks have been made since, by itself or by the opponent, who says
when it has moved).  Each image is read with :func:`hila_lang.worlds.tictactoe.reading.read_board`
(OpenCV): where the grid's cells are (their corners become the ICPs the program binds) and
which cells hold a cross or a circle (the board minimax plays on).

Looking again.  After every image the robot asks itself whether it is sure, from its own
measures only:

- a cell is *hidden*: more than 20 % of it neither paper nor ink, or covered by the robot's own
  arm where its joint angles say the arm is (:meth:`~hila_lang.robot.eyes.Eyes.body_outline`:
  its pen is never read as a mark);
- a cell's reading is *weak*: its confidence (how far the measure that decided it is from the
  decision's threshold, times the grid's contrast) is below :data:`SURE`;
- two images disagree about a cell, each sure of itself (the two eyes, or two looks);
- the board disagrees with its memory: a mark it saw before is gone or changed, or the number
  of new marks is not the number of moves made since it last looked.

It looks with its pen up: a pen low over the board (after a circle) first goes straight up to
``lift``, where the next reach starts anyway, so the arm makes no extra journey.  While in
doubt it takes the next view of :data:`VIEWS`: the other eye; the pen lifted (when it was not
yet); the pen taken ``aside``, beyond the board on the arm's side (both eyes); and last the gaze
moved onto the doubtful cells (both eyes).  Marks are decided by the images taken since the arm last
moved, each cell by the confidence-weighted vote of the images that saw it; corners are the
mean of those images' corners.  After going aside the pen comes back to ``lift``, so the
program's next reach starts where it would have.  When the last view still leaves a doubt the
robot plays on what it saw (the game goes on from its own reading) and the sighting lists the
cells it was unsure of; no view finding the grid at all is a
:class:`~hila_lang.core.errors.HilaRuntimeError`.

The table.  The paper's plane is not given: the robot starts from a rough prior (its spec's
``table_prior``: the iCub assumes a table 0.15 m below its waist, :mod:`hila_lang.robot.spec`), reads both eyes' images on it, and
triangulates the four inner crossings of the grid (cell 5's corners) from the two eyes
(:func:`hila_lang.perception.triangulation.triangulate`, the left eye placed by its joint
angles, the right one by the robot's calibration of the pair) -- only from two images that each
see the whole grid, and only when the four crossings come out level; the plane's height is the
median of every crossing triangulated so far (:class:`Table`), and the images of the arm's present
place are read again on it (those from where the arm was before no longer count).  The
first look always uses both eyes for that; later looks refine it whenever both eyes look.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ...core.errors import HilaRuntimeError, InputError, UnreachableError
from ...perception.learn import frame_name, IcpReading
from ...perception.triangulation import triangulate
from .board import cell_number, CORNER_NAMES
from .reading import read_board
from .rules import NAMES as _NAMES

#: the views tried in order while in doubt: (name, eye, where the arm is -- None: where the views
#: before left it --, where the eyes look)
VIEWS = (
    ("left eye", "left", "still", "board"),
    ("right eye", "right", "still", "board"),
    ("left eye (arm lifted)", "left", "lifted", "board"),
    ("right eye (arm lifted)", "right", "lifted", "board"),
    ("left eye (arm aside)", "left", "aside", "board"),
    ("right eye (arm aside)", "right", "aside", "board"),
    ("left eye (gaze on the doubtful cells)", "left", None, "doubt"),
    ("right eye (gaze on the doubtful cells)", "right", None, "doubt"),
)
#: a cell reading is sure at this confidence (halfway between its decision threshold and a clear
#: decision; see :mod:`.reading`)
SURE = 0.5
#: the grid lines' contrast (fraction of the paper's brightness) at which a reading is fully
#: trusted; lower contrast scales every confidence down (about 0.6 in the game's light)
GOOD_CONTRAST = 0.3
#: the pen is lifted only when it is more than this below the lift point, metres
LIFT_TOLERANCE = 0.005
#: with no prior from the robot's spec, the table is first assumed this far below the point the
#: eyes look at (only a start for reading the first images; the plane is then triangulated), metres
TABLE_PRIOR_BELOW_GAZE = 0.10
#: rounds of (read on the plane, triangulate, move the plane) at the first look
PLANE_ROUNDS = 1
#: a pair of images whose four crossings are not level within this (the table is flat) does not
#: place the table, metres (measured: 0.2-0.9 mm when both eyes see the whole grid)
TABLE_SPREAD = 0.002
#: images are read again when the table estimate moves by more than this, metres (0.2 mm of
#: height moves a corner seen 35 degrees off the vertical by 0.14 mm)
REREAD_DZ = 0.0002


class Table:
    """The robot's estimate of the table's height (the paper's plane z, world frame, metres).

    Every triangulated grid crossing is a sample; the height is their median.
    """

    def __init__(self, prior_z: float) -> None:
        self.prior_z = float(prior_z)
        self.samples: list[float] = []

    @property
    def known(self) -> bool:
        return bool(self.samples)

    @property
    def z(self) -> float:
        return float(np.median(self.samples)) if self.samples else self.prior_z

    def add(self, heights) -> None:
        self.samples.extend(float(h) for h in heights if np.isfinite(h))


@dataclass
class Memory:
    """What the robot remembers when it looks: the board it saw last (None: it has not looked
    yet) and how many marks have been made since (its own circles and the moves the opponent
    announced; None: unknown)."""

    board: tuple[str, ...] | None = None
    new_marks: int | None = None


@dataclass
class BoardSight:
    """What the robot's eyes made of the board at one look.

    Attributes
    ----------
    board : tuple of 9 str
        Marks read, cells 1..9, each in {"", "O", "X"}.
    corners : dict[int, dict[str, ndarray]]
        Cell (1..9) -> ``tl|tr|br|bl`` -> point (3,), world frame, metres (on the paper).
    views : list of dict
        Per image: ``view`` (name), ``occluded`` (cells), ``marks``, ``confidence``, or ``error``.
    arm : str
        Where the arm went to see the board: "still" (nowhere), "lifted" or "aside" (and back).
    unsure : list of int
        Cells still in doubt after the last view (decided by the vote anyway).
    doubts : list of str
        Why it looked again, in order.
    surface_z : float
        The table height the images were read on (the robot's estimate), metres.
    center : ndarray, shape (3,)
        The grid's centre, world, metres.
    """

    board: tuple[str, ...]
    corners: dict[int, dict[str, np.ndarray]]
    views: list[dict[str, Any]] = field(default_factory=list)
    arm: str = "still"
    unsure: list[int] = field(default_factory=list)
    doubts: list[str] = field(default_factory=list)
    surface_z: float = float("nan")
    center: np.ndarray | None = None


@dataclass
class _Image:
    view: str
    eye: str
    arm: str
    image: Any
    body: Any = None
    reading: Any = None
    error: str | None = None
    paired: bool = False


def look_at_board(eyes, hand, table: Table, memory: Memory, lift: np.ndarray | None = None,
                  aside: np.ndarray | None = None, *, read: Callable | None = None) -> BoardSight:
    """Read the board through ``eyes`` until sure (see the module docstring).

    Parameters
    ----------
    eyes
        The robot's eyes (:class:`~hila_lang.plugins.protocols.Eyes`).
    hand
        The robot's arm: ``hand.position()`` (3,) and ``hand.move(path (T, 3))``.
    table : Table
        The robot's estimate of the table; refined here when both eyes look.
    memory : Memory
    lift : ndarray, shape (3,), optional
        Where the pen goes straight up to (the next reach's start) and comes back to after
        going aside; None: the arm does not move.
    aside : ndarray, shape (3,), optional
        A pen position with the arm out of the eyes' view of the board; None: not used.
    read : callable, optional
        ``read(image, surface_z, body=OUTLINE) -> BoardReading``; default
        :func:`hila_lang.worlds.tictactoe.reading.read_board`.

    Raises
    ------
    HilaRuntimeError
        No view found the grid, or the table's height is still unknown (no two images, one from
        each eye, saw the whole grid).
    """
    if read is None:
        # lazy: only this branch needs it
        from .reading import read_board

        read = read_board
    right_T_left = np.asarray(eyes.stereo().right_T_left, dtype=float)
    images: list[_Image] = []
    doubts: list[str] = []
    arm = "still"
    skipped: set[str] = set()
    gaze = np.asarray(eyes.target, dtype=float).copy()
    unsure: list[int] = []
    result = None
    try:
        if lift is not None and _move_arm(hand, np.asarray(lift, dtype=float), straight_up=True):
            arm = "lifted"  # a pen low over the board (after a circle) goes up first: the next reach starts there
            skipped.add("still")
        for name, eye, where, look in VIEWS:
            where = arm if where is None else where
            if where in skipped:
                continue
            if where != arm:
                if lift is None or (where == "aside" and aside is None):
                    break
                if not _move_arm(hand, np.asarray(lift if where == "lifted" else aside, dtype=float),
                                 straight_up=where == "lifted"):
                    skipped.add(where)  # already that high (the same views again would not help), or out of reach
                    continue
                arm = where
            if look == "doubt" and result is not None:
                targets = unsure or list(range(1, 10))
                eyes.look_at(np.mean([np.mean(list(result[1][c].values()), axis=0) for c in targets], axis=0))
            shot = _Image(name, eye, arm, eyes.camera_image(eye), eyes.body_outline())
            images.append(shot)
            z_read = table.z
            _read(shot, read, z_read)
            if _update_table(images, table, read, right_T_left) and abs(table.z - z_read) > REREAD_DZ:
                for other in images:  # the arm's present place only: the others' readings no longer count
                    if other.arm == arm:
                        _read(other, read, table.z)
            current = [im for im in images if im.arm == arm and im.reading is not None]
            if not current or not table.known and len(images) < 2:
                if not current:
                    doubts.append(f"{name}: no grid found")
                continue
            result = _combine(current)
            unsure, reasons = _doubt(result, current, memory)
            if reasons:
                doubts.append(f"{name}: " + "; ".join(reasons))
            if not unsure and table.known:
                break
    finally:
        eyes.look_at(gaze)
        if arm == "aside":
            _move_arm(hand, np.asarray(lift, dtype=float), straight_up=False)
    if result is None or not table.known:
        found = "did not find the board" if result is None else "did not find the grid with both eyes at once"
        raise HilaRuntimeError(
            f"the robot's eyes {found}: "
            + "; ".join(f"{im.view}: {im.error or 'grid found'}" for im in images),
            hint="is the grid in the eye cameras' view? The robot finds the table's height from both eyes")
    board, corners, centre = result
    if table.known:  # the next look aims at the board as seen now (it may have been moved)
        eyes.look_at(centre)
    views = [{"view": im.view, "error": im.error} if im.reading is None else
             {"view": im.view, "occluded": sorted(int(c) for c in im.reading.occluded),
              "marks": list(im.reading.marks), "confidence": [round(c, 3) for c in _confidence(im.reading)]}
             for im in images]
    return BoardSight(tuple(board), corners, views, arm, sorted(unsure), doubts, table.z, centre)


def _read(shot: _Image, read: Callable, z: float) -> None:
    try:
        shot.reading, shot.error = read(shot.image, z, body=shot.body), None
    except InputError as exc:
        shot.reading, shot.error = None, str(exc).splitlines()[0]


def _update_table(images: list[_Image], table: Table, read: Callable, right_T_left: np.ndarray) -> bool:
    """Triangulate the grid's inner crossings (cell 5's corners) from the newest image and the
    other eye's latest image with the arm in the same place; True when the table estimate got
    new samples.  While the table is unknown, the pair is first read again on the plane its own
    crossings give (:data:`PLANE_ROUNDS` times): the prior may be centimetres off."""
    last = images[-1]
    pair = next((im for im in reversed(images[:-1]) if im.arm == last.arm and im.eye != last.eye), None)
    if pair is None or last.paired or pair.paired or not all(_whole(im) for im in (last, pair)):
        return False
    left, right = (last, pair) if last.eye == "left" else (pair, last)
    if not table.known:
        for _ in range(PLANE_ROUNDS):
            heights = _crossing_heights(left, right, right_T_left)
            if heights is None:
                return False
            for im in (left, right):
                _read(im, read, float(np.median(heights)))
            if left.reading is None or right.reading is None:
                return False
    heights = _crossing_heights(left, right, right_T_left)
    if heights is None or np.ptp(heights) > TABLE_SPREAD:
        return False
    left.paired = right.paired = True
    table.add(heights)
    return True


def _whole(shot: _Image) -> bool:
    """Whether an image saw the whole grid (no cell hidden): only those place the table."""
    return shot.reading is not None and not shot.reading.occluded


def _crossing_heights(left: _Image, right: _Image, right_T_left: np.ndarray) -> np.ndarray | None:
    """World z (4,) of the grid's inner crossings triangulated from two readings, or None.

    The left eye is placed by its joint angles, the right one relative to it by the robot's
    calibration of the pair (``right_T_left``), which keeps the two rays consistent with the
    calibrated intrinsics."""
    uv = {im.eye: im.image.project(np.array([im.reading.corners[5][n] for n in CORNER_NAMES]))
          for im in (left, right)}
    world_T_right = left.image.world_T_camera @ np.linalg.inv(right_T_left)
    try:
        xyz = triangulate(uv["left"], uv["right"], left.image.K, left.image.world_T_camera,
                          right.image.K, world_T_right)
    except InputError:
        return None
    return xyz[:, 2]


def _confidence(reading) -> list[float]:
    """Per cell, the reading's confidence scaled by the grid's contrast (see :data:`GOOD_CONTRAST`)."""
    scale = min(1.0, max(float(reading.contrast), 0.0) / GOOD_CONTRAST)
    return [float(c) * scale for c in reading.confidence]


def _combine(images: list[_Image]):
    """(board, corners, centre): per cell the confidence-weighted vote of the images that saw it
    (an occluded cell does not vote), corners and centre the images' mean."""
    board = []
    for cell in range(1, 10):
        votes: dict[str, float] = {}
        for im in images:
            if cell not in im.reading.occluded:
                mark = im.reading.marks[cell - 1]
                votes[mark] = votes.get(mark, 0.0) + _confidence(im.reading)[cell - 1] + 1e-6
        board.append(max(votes, key=votes.get) if votes else "")
    corners = {c: {n: np.mean([im.reading.corners[c][n] for im in images], axis=0) for n in CORNER_NAMES}
               for c in range(1, 10)}
    centre = np.mean([im.reading.center for im in images], axis=0)
    return board, corners, centre


def _doubt(result, images: list[_Image], memory: Memory) -> tuple[list[int], list[str]]:
    """The cells the robot is not sure of, and why (see the module docstring)."""
    board = result[0]
    cells: set[int] = set()
    reasons = []
    for cell in range(1, 10):
        seen = [im for im in images if cell not in im.reading.occluded]
        if not seen:
            cells.add(cell)
            reasons.append(f"cell {cell} hidden")
            continue
        sure = {im.reading.marks[cell - 1] for im in seen if _confidence(im.reading)[cell - 1] >= SURE}
        if not sure:
            cells.add(cell)
            reasons.append(f"cell {cell} unclear")
        elif len(sure) > 1:
            cells.add(cell)
            reasons.append(f"cell {cell} seen as " + " and as ".join(_NAMES[m] for m in sorted(sure)))
    if memory.board is not None:
        gone = [c for c in range(1, 10) if memory.board[c - 1] and board[c - 1] != memory.board[c - 1]]
        for c in gone:
            cells.add(c)
            reasons.append(f"cell {c} held {_NAMES[memory.board[c - 1]]} before, now {_NAMES[board[c - 1]]}")
        if memory.new_marks is not None:
            new = [c for c in range(1, 10) if board[c - 1] and not memory.board[c - 1]]
            if len(new) != memory.new_marks:
                suspects = new if len(new) > memory.new_marks else \
                    [c for c in range(1, 10) if not board[c - 1]]
                cells.update(suspects)
                reasons.append(f"{len(new)} new mark(s) where {memory.new_marks} were made since the last look")
    return sorted(cells), reasons


def _move_arm(hand, target: np.ndarray, *, straight_up: bool) -> bool:
    """Move the pen to ``target`` (3,); ``straight_up``: only up to its height, and only when
    the pen is more than :data:`LIFT_TOLERANCE` lower.  True when the arm moved; False when it
    did not need to, or could not (the place is out of reach: that view is skipped)."""
    here = np.asarray(hand.position(), dtype=float)
    if straight_up:
        if here[2] >= target[2] - LIFT_TOLERANCE:
            return False
        target = np.array([here[0], here[1], target[2]])
    try:
        hand.move(target[None])
    except UnreachableError:
        return False
    return True


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
    cells = cell_number(rel @ reading.right[:2] / reading.cell_size + 1.5, 1.5 - rel @ reading.far[:2] / reading.cell_size)
    if not cells.any():
        raise InputError("the pen touches the paper only outside the grid: cannot tell the demonstrated cell")
    return int(np.bincount(cells[cells > 0]).argmax())
