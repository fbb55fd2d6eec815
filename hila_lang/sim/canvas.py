"""A surface's texture as a raster that strokes are drawn into (the ink on the paper).

Pure numpy + OpenCV; a simulated scene uploads the image to PyBullet when it changes.

Texture frame: row 0 is the surface's far edge and column 0 its left edge as the robot sees it
(:mod:`hila_lang.sim.surface`).  A point at local coordinates (right, far) metres is at
``col = (right + across/2) * ppm - 0.5``, ``row = (depth/2 - far) * ppm - 0.5`` with ``ppm``
pixels per metre.
"""

from __future__ import annotations

import numpy as np

from .surface import Surface

#: texture resolution, pixels per metre (2 px/mm: an A4 sheet is 420 x 594 pixels)
PIXELS_PER_METRE = 2000.0
#: width of the pen's line, metres
PEN_WIDTH = 0.003
#: a blank sheet's colour, RGB
PAPER_RGB = (245, 245, 240)
#: ink colours by name, RGB
INK_RGB = {"robot": (20, 40, 200), "opponent": (200, 30, 30), "black": (0, 0, 0)}

_SHIFT = 4  # cv2 fixed-point bits for sub-pixel line ends


class Canvas:
    """The texture of one :class:`Surface`, starting from what is printed on it.

    Attributes
    ----------
    image : ndarray, shape (H, W, 3), uint8, RGB
    strokes : int
        How many strokes have been drawn (changes whenever the image does).
    """

    def __init__(self, surface: Surface, *, pixels_per_metre: float = PIXELS_PER_METRE) -> None:
        self.surface = surface
        self.ppm = float(pixels_per_metre)
        across, depth = surface.size
        self.width = max(2, int(round(across * self.ppm)))
        self.height = max(2, int(round(depth * self.ppm)))
        self.image = np.empty((self.height, self.width, 3), dtype=np.uint8)
        if surface.texture is None:
            self.image[:] = PAPER_RGB
        else:
            # lazy: loads cv2, which importing this module does not
            import cv2

            tex = np.asarray(surface.texture, dtype=np.uint8)
            self.image[:] = tex if tex.shape[:2] == (self.height, self.width) else cv2.resize(
                tex, (self.width, self.height), interpolation=cv2.INTER_AREA)
        self.strokes = 0

    def to_pixels(self, points: np.ndarray) -> np.ndarray:
        """Texture coordinates (N, 2) as (col, row), float pixels, of world points (N, 3)."""
        local = np.atleast_2d(self.surface.to_local(np.asarray(points, dtype=float)))
        across, depth = self.surface.size
        col = (local[:, 0] + across / 2) * self.ppm - 0.5
        row = (depth / 2 - local[:, 1]) * self.ppm - 0.5
        return np.column_stack([col, row])

    def draw_polyline(self, points: np.ndarray, *, color=INK_RGB["robot"], width: float = PEN_WIDTH) -> None:
        """Rasterise a stroke through world points (N, 3) (z ignored), anti-aliased.

        ``color`` is an RGB triple or a name from :data:`INK_RGB`; ``width`` in metres.
        """
        # lazy: loads cv2, which importing this module does not
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

    def ink_touching(self, points: np.ndarray, surface_z: float, tolerance: float, color="robot") -> int:
        """Draw the runs of a pen trace ``points`` (N, 3) that touch the surface -- over it, and
        at most ``tolerance`` above ``surface_z`` (or below) -- as strokes; returns how many
        points touched."""
        points = np.asarray(points, dtype=float)
        touching = self.surface.contains(points) & (points[:, 2] <= surface_z + tolerance)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], touching.astype(int), [0]])))
        for start, stop in zip(edges[::2], edges[1::2]):
            self.draw_polyline(points[start:stop], color=color)
        return int(touching.sum())
