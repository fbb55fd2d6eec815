"""The referee (``worlds/tictactoe/referee.py``): what it scores, how it perturbs the scene, and
the opponent's sloppy crosses.  No simulator: the back end's paper and lights are recorders."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hila_lang.worlds.tictactoe.board import Grid, cell_at, cell_center, cell_corners
from hila_lang.worlds.tictactoe.marks import SLOPPY_OVERLAP, cross_strokes
from hila_lang.worlds.tictactoe.referee import Referee, corner_errors

GRID = Grid.game()


class Paper:
    def __init__(self):
        self.moves, self.strokes = [], []

    def move_to(self, surface):
        self.moves.append(surface)

    def ink_polyline(self, points, color="opponent"):
        self.strokes.append(np.asarray(points))


class Lights:
    def __init__(self):
        self.levels = []

    def set_light(self, level, direction=None):
        self.levels.append((level, direction))


class Backend:
    def __init__(self):
        self.ink, self.lighting = Paper(), Lights()


def sight(board, corners=None, look=1, z=GRID.surface_z):
    return {"look": look, "board": tuple(board), "corners": corners or {c: cell_corners(GRID, c) for c in range(1, 10)},
            "views": [{"view": "left eye"}], "arm": "still", "unsure": [], "surface_z": z, "seconds": 0.1}


def test_a_sighting_is_scored_against_the_record_and_the_sheet():
    ref = Referee(GRID, "robot", 0)
    ref.record.board = ("X", "", "", "", "O", "", "", "", "")
    shifted = {c: {n: p + [0.001, 0.0, 0.0] for n, p in cell_corners(GRID, c).items()} for c in range(1, 10)}
    misreads = ref.score_sighting(sight(["", "", "", "", "O", "", "", "", "X"], shifted, z=GRID.surface_z + 0.0004))
    assert misreads == [{"look": 1, "moves_before": 0, "cell": 1, "seen": "", "true": "X"},
                        {"look": 1, "moves_before": 0, "cell": 9, "seen": "X", "true": ""}]
    look = ref.looks[0]
    assert look["corner_errors_m"].shape == (16,)  # the 4 x 4 points where cells meet
    assert look["corner_error_median_m"] == pytest.approx(0.001) and look["table_error_m"] == pytest.approx(0.0004)
    assert corner_errors({c: cell_corners(GRID, c) for c in range(1, 10)}, GRID).max() == 0.0


def test_a_circle_in_a_taken_cell_is_a_foul_and_the_record_keeps_the_first_mark():
    ref = Referee(GRID, "robot", 0)
    ref.record.board = ("", "", "", "", "X", "", "", "", "")
    circle = cell_center(GRID, 5) + 0.015 * np.column_stack([np.cos(np.linspace(0, 6.3, 40)),
                                                              np.sin(np.linspace(0, 6.3, 40)), np.zeros(40)])
    entry = {"state": "main/mark/draw", "planned": circle, "executed": circle}
    mark = ref.score_circle(entry, intended=5)
    assert mark["cell"] == 5 and mark["outside_cell_m"] == 0.0
    assert ref.fouls == [{"cell": 5, "foul": "drawn over X", "moves_before": 0}] and ref.record.board[4] == "X"
    ref.record.board = ("", "", "", "", "O", "", "", "", "")
    ref.score_circle({**entry, "planned": circle - cell_center(GRID, 5) + cell_center(GRID, 1),
                      "executed": circle - cell_center(GRID, 5) + cell_center(GRID, 1)})
    assert ref.fouls[-1] == {"cell": 1, "foul": "drawn out of turn", "moves_before": 0}


def test_bumps_push_and_turn_the_sheet_within_the_setting_seeded():
    def bumps(seed, bump):
        backend = Backend()
        ref = Referee(GRID, "robot", seed, bump=bump)
        ref.backend = backend
        events = [ref.perturb() for _ in range(40)]
        return ref, backend, events

    ref, backend, events = bumps(3, 0.03)
    shifts = [math.dist(s.center, GRID.grid_center) for s in backend.ink.moves]
    turns = [math.degrees(s.rotation - GRID.grid_rotation) for s in backend.ink.moves]
    assert max(shifts) <= 0.03 and max(shifts) > 0.02 and max(abs(t) for t in turns) <= 15.0
    assert max(abs(t) for t in turns) > 10.0
    assert backend.ink.moves[-1] == ref.grid.paper(printed=False) and ref.grid.grid_size == GRID.grid_size
    assert [e["board"]["shift_mm"] for e in events] == [round(1000 * s, 2) for s in shifts]
    assert events == bumps(3, 0.03)[2] and events != bumps(4, 0.03)[2]  # seeded
    small = bumps(3, 0.01)[1].ink.moves
    assert max(abs(math.degrees(s.rotation - GRID.grid_rotation)) for s in small) <= 5.0  # 15 deg x 1/3
    assert Referee(GRID, "robot", 0).perturb() is None  # nothing asked: nothing changes


def test_the_light_changes_between_the_setting_and_the_original():
    backend = Backend()
    ref = Referee(GRID, "robot", 0, light=0.5)
    ref.backend = backend
    for _ in range(30):
        ref.perturb()
    levels = [level for level, _ in backend.lighting.levels]
    assert 0.5 <= min(levels) < 0.6 and 0.9 < max(levels) <= 1.0
    for _, direction in backend.lighting.levels:
        assert np.linalg.norm(direction) == pytest.approx(1.0) and direction[2] > 0.6  # from above


@pytest.mark.parametrize("cell", range(1, 10))
def test_a_sloppy_cross_is_off_centre_and_over_a_grid_line_but_in_its_cell(cell):
    size = GRID.grid_size / 3
    for seed in range(12):
        strokes = cross_strokes(GRID, cell, np.random.default_rng(seed), sloppy=True)
        pts = np.vstack(strokes)
        centre = (strokes[0].mean(axis=0) + strokes[1].mean(axis=0)) / 2
        assert cell_at(GRID, centre) == cell
        local = GRID.world_to_grid(pts) - GRID.world_to_grid(cell_center(GRID, cell))
        row, col = divmod(cell - 1, 3)
        inner = [np.array(v, float) for v, ok in (((1, 0), col < 2), ((-1, 0), col > 0), ((0, 1), row > 0),
                                                   ((0, -1), row < 2)) if ok]  # sides that are grid lines
        over = max((local @ side).max() - size / 2 for side in inner)
        assert SLOPPY_OVERLAP[0] - 1e-9 <= over <= SLOPPY_OVERLAP[1] + 1e-9
    neat = cross_strokes(GRID, cell, np.random.default_rng(0))
    local = GRID.world_to_grid(np.vstack(neat)) - GRID.world_to_grid(cell_center(GRID, cell))
    assert np.abs(local).max() < size / 2  # a neat cross stays inside


def test_a_circle_drawn_out_of_turn_is_on_the_paper_so_seeing_it_is_no_misread():
    """The record keeps only the game's legal moves, but the ink of a circle drawn out of turn in
    an empty cell is on the paper: an eye that sees it there reads the paper right, and one that
    misses it does not."""
    ref = Referee(GRID, "robot", 0)
    ref.record.board = ("O", "", "O", "", "O", "", "X", "", "X")  # the opponent's turn
    circle = cell_center(GRID, 2) + 0.015 * np.column_stack([np.cos(np.linspace(0, 6.3, 40)),
                                                              np.sin(np.linspace(0, 6.3, 40)), np.zeros(40)])
    ref.score_circle({"state": "main/mark/draw", "planned": circle, "executed": circle}, intended=2)
    assert ref.fouls == [{"cell": 2, "foul": "drawn out of turn", "moves_before": 0}]
    assert ref.record.board[1] == "" and ref.to_move() == "opponent"  # the game's record: legal moves only
    assert ref.paper_marks() == ("O", "O", "O", "", "O", "", "X", "", "X")
    assert ref.score_sighting(sight(["O", "O", "O", "", "O", "", "X", "", "X"], look=1)) == []
    assert ref.score_sighting(sight(["O", "", "O", "", "O", "", "X", "", "X"], look=2)) == [
        {"look": 2, "moves_before": 0, "cell": 2, "seen": "", "true": "O"}]
    ref.record.board = ("O", "X", "O", "", "O", "", "X", "", "X")  # the opponent plays over it: its mark counts
    assert ref.paper_marks()[1] == "X"
