"""The paper's texture: a white sheet with the grid, onto which strokes are rasterised.

Pure numpy + OpenCV; the back end uploads the image to PyBullet once per stroke.

Texture frame: row 0 is the sheet's far edge and column 0 its left edge as the robot sees it
(so the image looks like the board seen from the robot's seat, cell 1 top-left).  A point at
grid coordinates (right, far) metres (see :meth:`SceneSpec.world_to_grid`) is at
``col = (right + across/2) * ppm``, ``row = (depth/2 - far) * ppm`` with ``ppm`` pixels per metre.
"""

from __future__ import annotations

import numpy as np

from .scene import SceneSpec

#: texture resolution, pixels per metre (2 px/mm: an A4 sheet is 420 x 594 pixels)
PIXELS_PER_METRE = 2000.0
#: width of the pen's line and of the printed grid, metres
PEN_WIDTH = 0.003
GRID_WIDTH = 0.002
PAPER_RGB = (245, 245, 240)
GRID_RGB = (40, 40, 40)
#: ink colours by name, RGB
INK_RGB = {"robot": (20, 40, 200), "opponent": (200, 30, 30), "black": (0, 0, 0)}

_SHIFT = 4  # cv2 fixed-point bits for sub-pixel line ends


class InkCanvas:
    """The paper texture of one :class:`SceneSpec`.

    Attributes
    ----------
    image : ndarray, shape (H, W, 3), uint8, RGB
    strokes : int
        How many strokes have been drawn (changes whenever the image does).
    """

    def __init__(self, scene: SceneSpec, *, pixels_per_metre: float = PIXELS_PER_METRE, draw_grid: bool = True) -> None:
        self.scene = scene
        self.ppm = float(pixels_per_metre)
        across, depth = scene.paper_size
        self.width = max(2, int(round(across * self.ppm)))
        self.height = max(2, int(round(depth * self.ppm)))
        self.image = np.empty((self.height, self.width, 3), dtype=np.uint8)
        self.image[:] = PAPER_RGB
        self.strokes = 0
        if draw_grid:
            for segment in scene.grid_lines():
                self.draw_polyline(segment, color=GRID_RGB, width=GRID_WIDTH)
            self.strokes = 0

    def to_pixels(self, points: np.ndarray) -> np.ndarray:
        """Texture coordinates (N, 2) as (col, row), float pixels, of world points (N, 3)."""
        grid = np.atleast_2d(self.scene.world_to_grid(np.asarray(points, dtype=float)))
        across, depth = self.scene.paper_size
        col = (grid[:, 0] + across / 2) * self.ppm - 0.5
        row = (depth / 2 - grid[:, 1]) * self.ppm - 0.5
        return np.column_stack([col, row])

    def draw_polyline(self, points: np.ndarray, *, color=INK_RGB["robot"], width: float = PEN_WIDTH) -> None:
        """Rasterise a stroke through world points (N, 3) (z ignored), anti-aliased.

        ``color`` is an RGB triple or a name from :data:`INK_RGB`; ``width`` in metres.
        """
        import cv2

        if isinstance(color, str):
            color = INK_RGB[color]
        pix = self.to_pixels(points)
        if len(pix) == 0:
            return
        fixed = np.round(pix * (1 << _SHIFT)).astype(np.int32).reshape(-1, 1, 2)
        thickness = max(1, int(round(width * self.ppm)))
        if len(pix) == 1:
            cv2.circle(self.image, tuple(fixed[0, 0]), int(thickness * (1 << _SHIFT) / 2), tuple(int(c) for c in color), -1, cv2.LINE_AA, _SHIFT)
        else:
            cv2.polylines(self.image, [fixed], False, tuple(int(c) for c in color), thickness, cv2.LINE_AA, _SHIFT)
        self.strokes += 1
