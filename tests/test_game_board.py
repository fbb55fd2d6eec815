"""Board geometry (pure numpy): cells, corners, frames, validation."""

import math

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.robot.workspace import TABLE_FRONT_X, TABLE_TOP_Z
from hila_lang.worlds.tictactoe.board import (
    CORNER_NAMES,
    DEMONSTRATION_DROP,
    Grid,
    cell_at,
    cell_center,
    cell_corners,
)


def test_game_board_is_smaller_rotated_and_higher_than_the_demonstration():
    demo, game = Grid.demonstration(), Grid.game()
    assert game.grid_size == pytest.approx(0.8 * demo.grid_size)
    assert math.degrees(game.grid_rotation - demo.grid_rotation) == pytest.approx(15.0)
    assert game.surface_z - demo.surface_z == pytest.approx(DEMONSTRATION_DROP)
    assert game.surface_z > TABLE_TOP_Z
    # the whole game grid is on the table and at least 0.20 m in front of the root
    corners = np.array([c for cell in range(1, 10) for c in cell_corners(game, cell).values()])
    assert corners[:, 0].min() >= 0.20 and corners[:, 0].min() > TABLE_FRONT_X


@pytest.mark.parametrize("spec", [Grid.game(), Grid.demonstration(), Grid((0.3, 0.1), 0.09, -1.0, 0.5)])
def test_cells_tile_the_grid_and_are_numbered_as_the_robot_sees_them(spec):
    size = spec.grid_size / 3
    right, far = spec.axes()
    for cell in range(1, 10):
        c = cell_corners(spec, cell)
        assert list(c) == list(CORNER_NAMES)
        # square of side grid/3, tl->tr goes to the robot's right, tl->bl comes nearer
        assert np.linalg.norm(c["tr"] - c["tl"]) == pytest.approx(size)
        assert (c["tr"] - c["tl"]) @ right == pytest.approx(size)
        assert (c["tl"] - c["bl"]) @ far == pytest.approx(size)
        np.testing.assert_allclose(np.mean(list(c.values()), axis=0), cell_center(spec, cell), atol=1e-12)
        assert all(p[2] == spec.surface_z for p in c.values())
        assert cell_at(spec, cell_center(spec, cell)) == cell
    # cell 1 is far-left, cell 9 near-right; neighbours share corners
    assert (cell_center(spec, 1) - cell_center(spec, 9)) @ far > 0
    assert (cell_center(spec, 9) - cell_center(spec, 1)) @ right > 0
    np.testing.assert_allclose(cell_corners(spec, 1)["tr"], cell_corners(spec, 2)["tl"], atol=1e-12)
    np.testing.assert_allclose(cell_corners(spec, 1)["bl"], cell_corners(spec, 4)["tl"], atol=1e-12)
    assert cell_at(spec, spec.grid_to_world(spec.grid_size, 0.0)) is None


def test_world_to_grid_inverts_grid_to_world():
    spec = Grid.game()
    rng = np.random.default_rng(1)
    rf = rng.uniform(-0.2, 0.2, size=(50, 2))
    np.testing.assert_allclose(spec.world_to_grid(spec.grid_to_world(rf[:, 0], rf[:, 1])), rf, atol=1e-12)


@pytest.mark.parametrize("cell", [0, 10, -1, 2.0, True, "5", None])
def test_bad_cell_is_an_input_error(cell):
    with pytest.raises(InputError, match="cell must be"):
        cell_corners(Grid.game(), cell)
    with pytest.raises(InputError, match="cell must be"):
        cell_center(Grid.game(), cell)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(grid_center=(0.3,), grid_size=0.1, grid_rotation=0, surface_z=0.5), "grid_center must be 2 numbers"),
        (dict(grid_center=(0.3, 0.0), grid_size=-0.1, grid_rotation=0, surface_z=0.5), "grid_size must be > 0"),
        (dict(grid_center=(0.3, 0.0), grid_size=0.1, grid_rotation=float("nan"), surface_z=0.5), "must be finite"),
        (dict(grid_center=(0.3, 0.0), grid_size=0.1, grid_rotation=0, surface_z="high"), "must be a number"),
        (dict(grid_center=(0.3, 0.0), grid_size=0.1, grid_rotation=0, surface_z=0.5, paper_size=(0.2, 0)), "paper_size"),
    ],
)
def test_bad_scene_spec_says_what_is_wrong(kwargs, message):
    with pytest.raises(InputError, match=message):
        Grid(**kwargs)
