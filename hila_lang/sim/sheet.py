"""A printed sheet that may be bent: its geometry and its mesh.  Pure numpy.

A :class:`Sheet` is a rectangle of ``size`` = (across, depth) metres lying on the table top
``z``, centred at ``center`` (x, y), turned by ``rotation`` about +z, with the frame of
:class:`hila_lang.sim.surface.Surface` (axes ``right`` and ``far``).  ``bend`` > 0 curls it
about an axis parallel to ``far``: its cross-section along ``right`` is a circular arc (the sheet
keeps its length along the arc) whose middle stands ``bend`` metres above the table and whose
two long edges rest on it -- a page that does not lie flat.  ``bend`` = 0 is a flat sheet.

Points on the sheet are named by *texture coordinates* (u, v) in [0, 1]: u from its left edge to
its right edge, v from its far edge to its near edge (row 0 of its texture is the far edge, as
:mod:`hila_lang.sim.surface` prints textures).  :meth:`Sheet.to_world` places them; that is the
simulator's truth (the mesh it renders, the referee's route), never the robot's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import InputError
from .surface import Surface


def _curvature(width: float, sagitta: float) -> float:
    """Curvature (1/m) of an arc of length ``width`` whose chord stands ``sagitta`` below its middle."""
    if sagitta <= 0:
        return 0.0
    lo, hi = 1e-9, 2 * math.pi / width * 0.999  # sagitta grows with the curvature up to a half circle
    if (1 - math.cos(hi * width / 2)) / hi < sagitta:
        raise InputError(f"a sheet {width:.3f} m across cannot be bent {sagitta:.3f} m high")
    for _ in range(80):
        k = (lo + hi) / 2
        lo, hi = (k, hi) if (1 - math.cos(k * width / 2)) / k < sagitta else (lo, k)
    return (lo + hi) / 2


@dataclass(frozen=True)
class Sheet:
    """A sheet on the table, flat or bent (see the module docstring).

    Attributes
    ----------
    center : (float, float)
        World (x, y) of its middle seen from above, metres.
    rotation : float
        About +z, radians.
    z : float
        The table top it lies on, metres.
    size : (float, float)
        (across, depth) along the sheet itself, metres.
    bend : float
        Height of its middle above the table, metres (0: flat).
    """

    center: tuple[float, float]
    rotation: float
    z: float
    size: tuple[float, float]
    bend: float = 0.0

    def __post_init__(self) -> None:
        if self.bend < 0 or min(self.size) <= 0:
            raise InputError(f"a sheet needs a positive size and a bend >= 0, got size {self.size}, bend {self.bend}")

    @property
    def flat(self) -> Surface:
        """The flat :class:`Surface` with the same centre, rotation, table height and size."""
        return Surface(self.center, self.rotation, self.z, self.size)

    def to_world(self, uv: np.ndarray) -> np.ndarray:
        """World points (N, 3) of texture coordinates ``uv`` (N, 2) (truth)."""
        uv = np.atleast_2d(np.asarray(uv, dtype=float))
        across, depth = self.size
        s = (uv[:, 0] - 0.5) * across  # arc length from the middle, along 'right'
        far = (0.5 - uv[:, 1]) * depth
        k = _curvature(across, self.bend)
        if k == 0.0:
            right, height = s, np.zeros_like(s)
        else:
            right = np.sin(k * s) / k
            height = self.bend - (1 - np.cos(k * s)) / k
        points = self.flat.to_world(right, far)
        points[:, 2] += height
        return points

    def to_uv(self, points: np.ndarray) -> np.ndarray:
        """Texture coordinates (N, 2) of world points (N, 3) on or near the sheet (the inverse of
        :meth:`to_world` for their position seen from above; truth)."""
        local = np.atleast_2d(self.flat.to_local(np.asarray(points, dtype=float)))
        k = _curvature(self.size[0], self.bend)
        s = local[:, 0] if k == 0.0 else np.arcsin(np.clip(k * local[:, 0], -1, 1)) / k
        return np.column_stack([s / self.size[0] + 0.5, 0.5 - local[:, 1] / self.size[1]])

    def corners(self) -> np.ndarray:
        """World (4, 3) of its corners tl, tr, br, bl (as :meth:`Surface.corners` names them)."""
        return self.to_world(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))

    def mesh(self, n_across: int = 24, n_depth: int = 8) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A triangle grid of the sheet: vertices (N, 3) world, texture coordinates (N, 2) and
        triangle indices (M,) (both windings, so it is seen from both sides)."""
        uv = np.column_stack([np.tile(np.linspace(0, 1, n_across + 1), n_depth + 1),
                              np.repeat(np.linspace(0, 1, n_depth + 1), n_across + 1)])
        tris = []
        for j in range(n_depth):
            for i in range(n_across):
                a = j * (n_across + 1) + i
                b, c, d = a + 1, a + n_across + 1, a + n_across + 2
                tris += [a, c, b, b, c, d, a, b, c, b, d, c]
        return self.to_world(uv), uv, np.array(tris, dtype=int)
