"""Board geometry: where the paper and the 3x3 grid are, in the world frame (pure numpy).

World frame: metres, z up, origin on the floor below the robot.  The iCub's root (waist) is
fixed at (0, 0, 0.62) facing +x; its right side is -y.  The table top is at z = 0.57 with its
front edge at x = 0.12 (see ``DESIGN.md`` section 4).

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

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: world z of the game table's top, metres
TABLE_TOP_Z = 0.57
#: world x of the game table's front edge (the edge nearest the robot), metres
TABLE_FRONT_X = 0.12
#: paper thickness, metres: the drawing surface is this far above the table top
PAPER_THICKNESS = 0.001
#: how far below the game table the demonstrator's low table is, metres (paper: "20 cm higher")
DEMONSTRATION_DROP = 0.20

CORNER_NAMES = ("tl", "tr", "br", "bl")

# (right, far) offsets of each corner from its cell centre, in half cell sizes
_CORNER_OFFSETS = {"tl": (-1.0, 1.0), "tr": (1.0, 1.0), "br": (1.0, -1.0), "bl": (-1.0, -1.0)}


@dataclass(frozen=True)
class SceneSpec:
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
                raise InputError(f"SceneSpec.{name} must be a number, got {value!r}")
            if not math.isfinite(float(value)):
                raise InputError(f"SceneSpec.{name} must be finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.grid_size <= 0:
            raise InputError(f"SceneSpec.grid_size must be > 0 metres, got {self.grid_size}")
        if min(paper) <= 0:
            raise InputError(f"SceneSpec.paper_size must be positive, got {paper}")

    @classmethod
    def demonstration(cls) -> "SceneSpec":
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
    def game(cls) -> "SceneSpec":
        """The robot's board: 20 % smaller (0.16 m), rotated 15 degrees, on the table, reachable."""
        return cls(
            grid_center=(0.31, -0.09),
            grid_size=0.16,
            grid_rotation=math.radians(15.0),
            surface_z=TABLE_TOP_Z + PAPER_THICKNESS,
        )

    # -- frames -------------------------------------------------------------------------------
    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors (right, far) of the grid in the world frame, each shape (3,), z = 0."""
        c, s = math.cos(self.grid_rotation), math.sin(self.grid_rotation)
        far = np.array([c, s, 0.0])
        right = np.array([s, -c, 0.0])
        return right, far

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
        r_axis, f_axis = self.axes()
        origin = np.array([self.grid_center[0], self.grid_center[1], self.surface_z])
        right = np.asarray(right, dtype=float)
        far = np.asarray(far, dtype=float)
        return origin + right[..., None] * r_axis + far[..., None] * f_axis

    def world_to_grid(self, points: np.ndarray) -> np.ndarray:
        """Grid coordinates (right, far) of world points, shape (..., 2); z is ignored."""
        pts = np.asarray(points, dtype=float)
        if pts.shape[-1] not in (2, 3):
            raise InputError(f"expected points of shape (..., 3), got {pts.shape}")
        r_axis, f_axis = self.axes()
        d = pts[..., :2] - np.asarray(self.grid_center)
        return np.stack([d @ r_axis[:2], d @ f_axis[:2]], axis=-1)

    def paper_corners(self) -> np.ndarray:
        """The sheet's corners on the surface, shape (4, 3), order tl, tr, br, bl."""
        hw, hd = self.paper_size[0] / 2, self.paper_size[1] / 2
        right = np.array([-hw, hw, hw, -hw])
        far = np.array([hd, hd, -hd, -hd])
        return self.grid_to_world(right, far)

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
        raise InputError(f"SceneSpec.{name} must be {n} numbers, got {value!r}") from None
    if arr.shape != (n,):
        raise InputError(f"SceneSpec.{name} must be {n} numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"SceneSpec.{name} must be finite, got {value!r}")
    return tuple(float(v) for v in arr)


def _check_cell(cell) -> int:
    if isinstance(cell, bool) or not isinstance(cell, (int, np.integer)):
        raise InputError(f"cell must be an integer 1..9, got {cell!r}")
    if not 1 <= int(cell) <= 9:
        raise InputError(f"cell must be 1..9 (1 = far-left, 9 = near-right), got {int(cell)}")
    return int(cell)


def _cell_grid_center(spec: SceneSpec, cell: int) -> tuple[float, float]:
    row, col = divmod(cell - 1, 3)
    step = spec.grid_size / 3
    return (col - 1) * step, (1 - row) * step


def cell_center(spec: SceneSpec, cell: int) -> np.ndarray:
    """Centre of ``cell`` (1..9, 1 = far-left) on the paper surface, shape (3,), world, metres.

    Raises
    ------
    InputError
        ``cell`` is not an integer in 1..9.
    """
    cell = _check_cell(cell)
    right, far = _cell_grid_center(spec, cell)
    return spec.grid_to_world(right, far)


def cell_corners(spec: SceneSpec, cell: int) -> dict[str, np.ndarray]:
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
    cell = _check_cell(cell)
    right, far = _cell_grid_center(spec, cell)
    half = spec.grid_size / 6
    return {
        name: spec.grid_to_world(right + dr * half, far + df * half)
        for name, (dr, df) in _CORNER_OFFSETS.items()
    }


def cell_at(spec: SceneSpec, point: np.ndarray) -> int | None:
    """The cell (1..9) containing ``point`` (shape (3,) or (2,), world) seen from above, or None."""
    right, far = spec.world_to_grid(np.asarray(point, dtype=float))
    step = spec.grid_size / 3
    col = math.floor((right + spec.grid_size / 2) / step)
    row = math.floor((spec.grid_size / 2 - far) / step)
    if 0 <= row < 3 and 0 <= col < 3:
        return row * 3 + col + 1
    return None
