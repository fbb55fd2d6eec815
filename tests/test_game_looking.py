"""The robot's looking (``worlds/tictactoe/vision.py``) and its side of the game (``player.py``),
with scripted eyes and readings: when it looks again, what it decides, and from what.

No simulator: each "image" is a token, and the reader returns the reading scripted for it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

from hila_lang.core.errors import HilaRuntimeError, InputError
from hila_lang.sim.camera import intrinsics, look_at, project
from hila_lang.worlds.tictactoe.board import Grid, cell_corners
from hila_lang.worlds.tictactoe.player import Hand, Player
from hila_lang.worlds.tictactoe.vision import VIEWS, Memory, Table, look_at_board

GRID = Grid.game()
EMPTY = [""] * 9


@dataclass
class Reading:
    """What :func:`read_board` returns, scripted."""

    marks: list
    occluded: list = field(default_factory=list)
    confidence: list = field(default_factory=lambda: [1.0] * 9)
    contrast: float = 0.6
    corners: dict = field(default_factory=lambda: {c: cell_corners(GRID, c) for c in range(1, 10)})
    center: np.ndarray = field(default_factory=lambda: GRID.grid_to_world(0.0, 0.0))


CAMERAS = {eye: look_at((0.05, side, 0.95), GRID.grid_to_world(0.0, 0.0)) for eye, side in (("left", 0.034),
                                                                                              ("right", -0.034))}


@dataclass
class Image:
    """An eye image: its number (what the scripted reader looks up) and its camera."""

    index: int
    eye: str
    K: np.ndarray = field(default_factory=lambda: intrinsics(320, 240, 64.0))

    @property
    def world_T_camera(self):
        return CAMERAS[self.eye]

    def project(self, points):
        return project(points, self.K, self.world_T_camera)


class Eyes:
    """Eyes whose images are numbered in the order they are taken."""

    def __init__(self):
        self.target = GRID.grid_to_world(0.0, 0.0)
        self.taken: list[str] = []
        self.aims: list[np.ndarray] = []

    def look_at(self, point):
        self.aims.append(np.asarray(point, float))
        self.target = np.asarray(point, float)
        return 0.0

    def camera_image(self, eye="left"):
        self.taken.append(eye)
        return Image(len(self.taken) - 1, eye)

    def body_outline(self):
        return []

    def stereo(self):
        class Pair:
            right_T_left = np.linalg.inv(CAMERAS["right"]) @ CAMERAS["left"]
        return Pair()


class Arm:
    def __init__(self, at):
        self.at = np.asarray(at, float)
        self.moves: list[np.ndarray] = []

    def position(self):
        return self.at.copy()

    def move(self, path):
        self.moves.append(np.asarray(path, float)[-1])
        self.at = self.moves[-1].copy()


def scripted(readings):
    """A reader returning ``readings[i]`` for image ``i`` (an InputError for a string)."""
    def read(image, surface_z, body=None):
        r = readings[image.index]
        if isinstance(r, str):
            raise InputError(r)
        return r
    return read


def known_table():
    table = Table(0.47)
    table.add([GRID.surface_z] * 4)
    return table


LIFT = GRID.grid_to_world(0.0, 0.0) + [0.0, 0.0, 0.10]
ASIDE = GRID.grid_to_world(0.14, -0.08) + [0.0, 0.0, 0.10]


def test_a_clear_view_is_enough():
    eyes, arm = Eyes(), Arm(LIFT)
    marks = ["", "", "X", "", "O", "", "", "", ""]
    sight = look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(), LIFT, ASIDE,
                          read=scripted([Reading(marks)]))
    assert sight.board == tuple(marks) and sight.unsure == [] and sight.arm == "still"
    assert eyes.taken == ["left"] and arm.moves == []


def test_a_pen_low_over_the_board_goes_straight_up_before_the_robot_looks():
    low = LIFT - [0, 0, 0.05]  # after a circle
    eyes, arm = Eyes(), Arm(low)
    sight = look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(), LIFT, ASIDE,
                          read=scripted([Reading(EMPTY)]))
    assert [v["view"] for v in sight.views] == ["left eye (arm lifted)"] and sight.arm == "lifted"
    np.testing.assert_allclose(arm.moves, [[*low[:2], LIFT[2]]])  # straight up, and it stays there


def test_a_hidden_cell_makes_it_take_the_other_eye_then_the_arm_aside():
    eyes, arm = Eyes(), Arm(LIFT)
    hidden = Reading(["", "", "", "", "O", "", "", "", ""], occluded=[3], confidence=[1] * 2 + [0] + [1] * 6)
    clear = Reading(["", "", "X", "", "O", "", "", "", ""])
    sight = look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(), LIFT, ASIDE,
                          read=scripted([hidden, hidden, clear]))
    assert [v["view"] for v in sight.views] == ["left eye", "right eye", "left eye (arm aside)"]
    assert sight.board[2] == "X" and sight.arm == "aside" and sight.unsure == []
    assert sight.doubts == ["left eye: cell 3 hidden", "right eye: cell 3 hidden"]
    np.testing.assert_allclose(arm.moves, [ASIDE, LIFT])  # aside to look, and back to the lift point


def test_eyes_that_disagree_are_a_doubt_resolved_by_the_next_views():
    eyes, arm = Eyes(), Arm(LIFT)  # the pen is at the lift point already: no "arm lifted" views
    left = Reading(["", "", "", "", "O", "", "", "", "X"], occluded=[3])
    right = Reading(["", "", "", "", "O", "", "", "", "O"])
    sight = look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(), LIFT, ASIDE,
                          read=scripted([left, right, Reading(list(left.marks))]))
    assert sight.doubts == ["left eye: cell 3 hidden", "right eye: cell 9 seen as the robot's mark (O) and as a cross (X)"]
    assert [v["view"] for v in sight.views] == ["left eye", "right eye", "left eye (arm aside)"]
    assert sight.arm == "aside" and sight.board[8] == "X" and sight.unsure == []
    np.testing.assert_allclose(arm.moves, [ASIDE, LIFT])  # aside to look, and back to the lift point


def test_a_board_that_contradicts_its_memory_makes_it_look_again():
    eyes, arm = Eyes(), Arm(LIFT)
    before = ("", "", "", "", "O", "", "", "", "")
    missed = Reading(list(before))  # the opponent said it moved, but no new mark is seen
    seen = Reading(["", "", "", "", "O", "X", "", "", ""])
    sight = look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(before, 1), LIFT, ASIDE,
                          read=scripted([missed, seen, seen]))
    assert "0 new mark(s) where 1 were made since the last look" in sight.doubts[0]
    assert "cell 6 seen as empty and as a cross (X)" in sight.doubts[1]  # the two eyes disagree
    assert sight.board[5] == "X" and sight.unsure == [] and sight.arm == "aside"


def test_when_every_view_leaves_a_doubt_it_plays_on_what_it_saw_and_says_so():
    eyes, arm = Eyes(), Arm(LIFT)
    weak = Reading(["X", "", "", "", "", "", "", "", ""], confidence=[0.2] + [1.0] * 8)
    sight = look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(), LIFT, ASIDE,
                          read=scripted([weak] * len(VIEWS)))
    # every view but the lifted ones (the pen is up already)
    assert [v["view"] for v in sight.views] == [v[0] for v in VIEWS if v[2] != "lifted"]
    assert sight.unsure == [1] and sight.board[0] == "X"
    # the gaze moved onto the doubtful cell, then back onto the board's centre
    np.testing.assert_allclose(eyes.aims[0], np.mean(list(cell_corners(GRID, 1).values()), axis=0))
    np.testing.assert_allclose(eyes.aims[-1], GRID.grid_to_world(0.0, 0.0))
    np.testing.assert_allclose(arm.at, LIFT)  # came back to the lift point from aside


def test_no_grid_in_any_view_is_a_clear_error():
    eyes, arm = Eyes(), Arm(LIFT)
    with pytest.raises(HilaRuntimeError, match="the robot's eyes did not find the board: left eye: error: no grid"):
        look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(), LIFT, ASIDE,
                      read=scripted(["no grid found on the sheet"] * len(VIEWS)))


def test_low_contrast_makes_every_reading_weak():
    eyes, arm = Eyes(), Arm(LIFT)
    dim = Reading(["", "", "", "", "O", "", "", "", ""], contrast=0.1)
    sight = look_at_board(eyes, Hand(arm.position, arm.move), known_table(), Memory(), LIFT, ASIDE,
                          read=scripted([dim, Reading(list(dim.marks))]))
    assert "unclear" in sight.doubts[0] and len(sight.views) == 2


def test_the_table_is_not_given_the_first_look_needs_both_eyes():
    with pytest.raises(HilaRuntimeError, match="did not find the grid with both eyes at once"):
        eyes, arm = Eyes(), Arm(LIFT)
        look_at_board(eyes, Hand(arm.position, arm.move), Table(0.47), Memory(), None, None,
                      read=scripted([Reading(EMPTY), "no sheet of paper found in the image"]))


def logged(readings, log):
    """:func:`scripted`, noting each read as (image, the table height it was read on)."""
    read = scripted(readings)

    def logging(image, surface_z, body=None):
        log.append((image.index, round(float(surface_z), 6)))
        return read(image, surface_z, body)
    return logging


def test_the_first_look_reads_again_only_the_views_that_count():
    """The first look: both eyes with the arm still (a cell hidden: they cannot place the table),
    then both with the arm aside, which place it.  Those two are read on the prior height, on the
    height their crossings give, and on the table that makes; the still views, whose readings no
    longer count, are not read again.  A later pair that moves the table by more than
    ``REREAD_DZ`` has its images read again on it."""
    from hila_lang.worlds.tictactoe.vision import REREAD_DZ

    hidden = Reading(EMPTY, occluded=[3], confidence=[1] * 2 + [0] + [1] * 6)
    log: list = []
    table = Table(0.47)
    eyes, arm = Eyes(), Arm(LIFT)
    sight = look_at_board(eyes, Hand(arm.position, arm.move), table, Memory(), LIFT, ASIDE,
                          read=logged([hidden, hidden, Reading(EMPTY), Reading(EMPTY)], log))
    z = round(GRID.surface_z, 6)
    assert table.known and table.z == pytest.approx(GRID.surface_z, abs=1e-9) and sight.arm == "aside"
    assert log == [(0, 0.47), (1, 0.47), (2, 0.47), (3, 0.47), (2, z), (3, z), (2, z), (3, z)]

    log.clear()
    off = Table(0.47)
    off.add([GRID.surface_z + 3 * REREAD_DZ] * 4)  # known, but off: both eyes' crossings move it
    eyes = Eyes()
    look_at_board(eyes, Hand(arm.position, arm.move), off, Memory(), LIFT, ASIDE,
                  read=logged([Reading(["", "", "", "", "O", "", "", "", ""], confidence=[1] * 4 + [0.2] + [1] * 4),
                               Reading(EMPTY)], log))
    moved = round(off.z, 6)
    assert abs(off.z - (GRID.surface_z + 3 * REREAD_DZ)) > REREAD_DZ
    assert log == [(0, round(GRID.surface_z + 3 * REREAD_DZ, 6)), (1, round(GRID.surface_z + 3 * REREAD_DZ, 6)),
                   (0, moved), (1, moved)]


# --------------------------------------------------------------------------- the player's decisions

class Seeing(Player):
    """A player whose sightings are scripted boards."""

    def __init__(self, boards, first="robot"):
        super().__init__(first, LIFT, eyes=Eyes(), hand=Hand(lambda: LIFT.copy(), lambda path: None))
        self.boards = list(boards)

    def sight(self):
        if self._stale or not self.sightings:
            board = tuple(self.boards.pop(0))
            self.sightings.append({"look": len(self.sightings) + 1, "board": board,
                                   "corners": {c: cell_corners(GRID, c) for c in range(1, 10)}})
            self._stale = False
        return self.sightings[-1]


@pytest.mark.parametrize("first, board, turn", [
    ("robot", EMPTY, "robot"), ("robot", ["X", "", "", "", "O", "", "", "", ""], "robot"),
    ("robot", ["", "", "", "", "O", "", "", "", ""], "opponent"), ("opponent", EMPTY, "opponent"),
    ("opponent", ["X", "", "", "", "", "", "", "", ""], "robot"), ("robot", ["O", "O", "O", "X", "X", "", "", "", ""], None),
])
def test_whose_turn_comes_from_the_marks_it_sees(first, board, turn):
    assert Seeing([board], first).to_move() == turn


def test_it_plays_minimax_on_the_board_it_sees_and_binds_pressed_corners():
    player = Seeing([["X", "X", "", "", "O", "", "", "", ""]])
    assert player.best_move() == 3  # block the row
    corners = player.corners()
    np.testing.assert_allclose(corners[3]["tl"], cell_corners(GRID, 3)["tl"] - [0, 0, 0.0005])


def test_it_looks_again_only_after_a_move():
    player = Seeing([EMPTY, ["", "", "", "", "O", "", "", "", ""]])
    player.board(), player.board()
    assert len(player.sightings) == 1
    circle = GRID.grid_to_world(0.0, 0.0) + np.array([[0.01, 0, 0], [0, 0.01, 0], [-0.01, 0, 0]])
    assert player.drew(circle) == 5 and player.own == [5]
    assert player.board()[4] == "O" and len(player.sightings) == 2


def test_a_blind_player_plays_from_the_moves_it_made_and_was_told():
    player = Player("robot", LIFT)
    assert player.best_move() == 5
    player.drew(np.array([GRID.grid_to_world(0.0, 0.0)]))
    player.opponent_moved(1)
    assert player.board() == ("X", "", "", "", "O", "", "", "", "") and player.to_move() == "robot"
    assert player.last_move() == 5


def test_an_aside_place_out_of_reach_is_skipped_not_fatal():
    from hila_lang.core.errors import UnreachableError

    eyes, arm = Eyes(), Arm(LIFT)

    def move(path):
        if np.allclose(np.asarray(path)[-1], ASIDE):
            raise UnreachableError("cannot reach the aside place")
        arm.move(path)

    hidden = Reading(EMPTY, occluded=[3], confidence=[1] * 2 + [0] + [1] * 6)
    sight = look_at_board(eyes, Hand(arm.position, move), known_table(), Memory(), LIFT, ASIDE,
                          read=scripted([hidden, hidden, Reading(EMPTY), Reading(EMPTY)]))
    assert [v["view"] for v in sight.views] == ["left eye", "right eye", "left eye (gaze on the doubtful cells)"]
    assert sight.unsure == [] and arm.moves == []
