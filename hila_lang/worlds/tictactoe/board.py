"""Board geometry: where the paper and the 3x3 grid are, in the world frame (pure numpy).

World frame: metres, z up (see :mod:`hila_lang.robot.workspace` for the table).  The grid is
printed on a sheet (:meth:`Grid.paper`, a :class:`~hila_lang.sim.surface.Surface` whose texture
shows the grid lines); the robot and the simulator know only that sheet, not the grid.

Grid frame.  Cells are numbered 1..9 row-major *as the robot sees them*: cell 1 is far-left,
cell 3 far-right, cell 9 near-right.  "Far" is away from the robot (+x when the grid is not
rotated) and "right" is the robot's right (-y when not rotated).  The grid is rotated by
``grid_rotation`` radians about +z around its centre.  Cell corners are named like an image
the robot looks at: ``tl`` (far-left), ``tr`` (far-right), ``br`` (near-right), ``bl``
(near-left).

The paper is centred on the grid and rotated with it; ``paper_size`` is (extent along the grid's
rows, i.e. the robot's left-right, extent along the grid's columns, i.e. depth), metres.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ...core.errors import InputError
from ...robot.workspace import PAPER_THICKNESS, TABLE_TOP_Z
from ...sim.canvas import Canvas
from ...sim.surface import Surface

#: width of the printed grid's lines, metres, and their colour (RGB)
GRID_WIDTH = 0.002
GRID_RGB = (40, 40, 40)
#: how far below the game table the demonstrator's low table is, metres (paper: "20 cm higher")
DEMONSTRATION_DROP = 0.20

CORNER_NAMES = ("tl", "tr", "br", "bl")

# (right, far) offsets of each corner from its cell centre, in half cell sizes
_CORNER_OFFSETS = {"tl": (-1.0, 1.0), "tr": (1.0, 1.0), "br": (1.0, -1.0), "bl": (-1.0, -1.0)}


@dataclass(frozen=True)
class Grid:
    """Where the paper and grid are.

    Attributes
    ----------
    grid_center : tuple of float
        (x, y) of the grid's centre, world frame, metres.
    grid_size : float
        Side of the whole 3x3 grid, metres (a cell is ``grid_size / 3``).
    grid_rotation : float
        Rotation of the grid (and paper) about +z, radians, counter-clockwise seen from above.
    surface_z : float
        World z of the paper's top surface, metres (the pen draws at this height).
    paper_size : tuple of float
        (across, depth) of the sheet, metres; A4 portrait by default.
    """

    grid_center: tuple[float, float]
    grid_size: float
    grid_rotation: float
    surface_z: float
    paper_size: tuple[float, float] = (0.210, 0.297)

    def __post_init__(self) -> None:
        center = _finite_tuple(self.grid_center, 2, "grid_center")
        paper = _finite_tuple(self.paper_size, 2, "paper_size")
        object.__setattr__(self, "grid_center", center)
        object.__setattr__(self, "paper_size", paper)
        for name in ("grid_size", "grid_rotation", "surface_z"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise InputError(f"Grid.{name} must be a number, got {value!r}")
            if not math.isfinite(float(value)):
                raise InputError(f"Grid.{name} must be finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.grid_size <= 0:
            raise InputError(f"Grid.grid_size must be > 0 metres, got {self.grid_size}")
        if min(paper) <= 0:
            raise InputError(f"Grid.paper_size must be positive, got {paper}")

    @classmethod
    def demonstration(cls) -> "Grid":
        """The demonstrator's scene: an A4 sheet with a 0.20 m grid, not rotated, on a low table.

        The low table's top is 0.20 m below the game table (z = 0.37); the paper lies on it.
        The sheet is in front of the robot where both eye cameras see it (the human draws there,
        the robot watches); it need not be reachable.
        """
        return cls(
            grid_center=(0.32, -0.07),
            grid_size=0.20,
            grid_rotation=0.0,
            surface_z=TABLE_TOP_Z - DEMONSTRATION_DROP + PAPER_THICKNESS,
        )

    @classmethod
    def game(cls) -> "Grid":
        """The robot's board: 20 % smaller (0.16 m), rotated 15 degrees, on the table, reachable."""
        return cls(
            grid_center=(0.31, -0.09),
            grid_size=0.16,
            grid_rotation=math.radians(15.0),
            surface_z=TABLE_TOP_Z + PAPER_THICKNESS,
        )

    # -- frames -------------------------------------------------------------------------------
    def paper(self, printed: bool = True) -> Surface:
        """The sheet the grid is printed on, centred on the grid and turned with it; its texture
        shows the grid lines (``printed``), else it is blank."""
        blank = self._sheet
        if not printed:
            return blank

        canvas = Canvas(blank)
        for segment in self.grid_lines():
            canvas.draw_polyline(segment, color=GRID_RGB, width=GRID_WIDTH)
        return Surface(self.grid_center, self.grid_rotation, self.surface_z, self.paper_size, texture=canvas.image)

    @functools.cached_property
    def _sheet(self) -> Surface:
        return Surface(self.grid_center, self.grid_rotation, self.surface_z, self.paper_size)

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors (right, far) of the grid in the world frame, each shape (3,), z = 0."""
        return self._sheet.axes()

    def grid_to_world(self, right: float | np.ndarray, far: float | np.ndarray) -> np.ndarray:
        """World points on the surface from grid coordinates (metres from the grid centre).

        Parameters
        ----------
        right, far : float or array of shape (N,)
            Offsets along the robot's right and away from the robot, grid frame, metres.

        Returns
        -------
        ndarray, shape (3,) or (N, 3)
        """
        return self._sheet.to_world(right, far)

    def world_to_grid(self, points: np.ndarray) -> np.ndarray:
        """Grid coordinates (right, far) of world points, shape (..., 2); z is ignored."""
        return self._sheet.to_local(points)

    def paper_corners(self) -> np.ndarray:
        """The sheet's corners on the surface, shape (4, 3), order tl, tr, br, bl."""
        return self._sheet.corners()

    def grid_lines(self) -> list[np.ndarray]:
        """The four inner grid lines as segments, each shape (2, 3), on the surface.

        Two run across (constant ``far``), two in depth (constant ``right``); they span the
        whole grid, like a hand-drawn tic-tac-toe board.
        """
        h = self.grid_size / 2
        third = self.grid_size / 6
        segments = []
        for k in (-third, third):
            segments.append(self.grid_to_world(np.array([-h, h]), np.array([k, k])))
            segments.append(self.grid_to_world(np.array([k, k]), np.array([-h, h])))
        return segments


def _finite_tuple(value, n: int, name: str) -> tuple[float, ...]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"Grid.{name} must be {n} numbers, got {value!r}") from None
    if arr.shape != (n,):
        raise InputError(f"Grid.{name} must be {n} numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"Grid.{name} must be finite, got {value!r}")
    return tuple(float(v) for v in arr)


def _check_cell(cell) -> int:
    if isinstance(cell, bool) or not isinstance(cell, (int, np.integer)):
        raise InputError(f"cell must be an integer 1..9, got {cell!r}")
    if not 1 <= int(cell) <= 9:
        raise InputError(f"cell must be 1..9 (1 = far-left, 9 = near-right), got {int(cell)}")
    return int(cell)


def _cell_grid_center(spec: Grid, cell: int) -> tuple[float, float]:
    row, col = divmod(cell - 1, 3)
    step = spec.grid_size / 3
    return (col - 1) * step, (1 - row) * step


def _cell_points(spec: Grid, cell, offsets: dict) -> dict[str, np.ndarray]:
    """Points of ``cell`` at (right, far) ``offsets`` in half cell sizes from its centre."""
    cell = _check_cell(cell)
    right, far = _cell_grid_center(spec, cell)
    half = spec.grid_size / 6
    return {name: spec.grid_to_world(right + dr * half, far + df * half) for name, (dr, df) in offsets.items()}


def cell_center(spec: Grid, cell: int) -> np.ndarray:
    """Centre of ``cell`` (1..9, 1 = far-left) on the paper surface, shape (3,), world, metres.

    Raises
    ------
    InputError
        ``cell`` is not an integer in 1..9.
    """
    return _cell_points(spec, cell, {"centre": (0.0, 0.0)})["centre"]


def cell_corners(spec: Grid, cell: int) -> dict[str, np.ndarray]:
    """The four corners of ``cell`` on the paper surface, world frame, metres.

    Returns
    -------
    dict
        ``{"tl", "tr", "br", "bl"}`` -> array of shape (3,): far-left, far-right, near-right,
        near-left as the robot sees the board.

    Raises
    ------
    InputError
        ``cell`` is not an integer in 1..9.
    """
    return _cell_points(spec, cell, _CORNER_OFFSETS)


def cell_number(col, row) -> np.ndarray:
    """The cells (1..9; 0 outside the grid) at grid positions counted in cell sizes: ``col`` from
    the grid's left edge, ``row`` from its far edge (0..3 inside), scalars or arrays alike."""
    c, r = np.floor(col).astype(int), np.floor(row).astype(int)
    return np.where((c >= 0) & (c < 3) & (r >= 0) & (r < 3), r * 3 + c + 1, 0)


def cell_at(spec: Grid, point: np.ndarray) -> int | None:
    """The cell (1..9) containing ``point`` (shape (3,) or (2,), world) seen from above, or None."""
    right, far = spec.world_to_grid(np.asarray(point, dtype=float))
    step = spec.grid_size / 3
    return int(cell_number(right / step + 1.5, 1.5 - far / step)) or None
