"""A flat drawing surface (a sheet of paper) and the scene a world hands a back end.  Pure numpy.

Frames.  World frame: metres, z up; the robot faces +x (its right is -y).  A surface lies on the
horizontal plane ``z`` (its top), centred at ``center`` (x, y), turned by ``rotation`` radians
about +z (counter-clockwise seen from above).  Its own axes are ``far`` (away from the robot:
+x when not rotated) and ``right`` (the robot's right: -y when not rotated); local coordinates
(right, far) are metres from its centre.  Its corners are named as the robot sees them:
``tl`` far-left, ``tr`` far-right, ``br`` near-right, ``bl`` near-left.

A texture is an RGB image (H, W, 3) uint8 printed on the surface: row 0 along the far edge,
column 0 along the left edge (the sheet as the robot sees it from its seat).

Nothing here knows what is printed on a surface or what a program draws on it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..core.errors import InputError

#: the pen touches a surface when its tip is at most this far above it, metres (it inks there)
CONTACT_TOLERANCE = 0.0005


def _finite(value, n: int, name: str) -> tuple[float, ...]:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"Surface.{name} must be {n} numbers, got {value!r}") from None
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise InputError(f"Surface.{name} must be {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


@dataclass(frozen=True)
class Surface:
    """A flat rectangle on the plane ``z`` (see the module docstring).

    Attributes
    ----------
    center : (float, float)
        World (x, y) of its centre, metres.
    rotation : float
        About +z, radians.
    z : float
        World z of its top (where a pen draws), metres.
    size : (float, float)
        (across, depth): extent along ``right`` and along ``far``, metres (A4 portrait by default).
    texture : ndarray (H, W, 3) uint8, or None
        What is printed on it; None is a blank sheet.
    """

    center: tuple[float, float]
    rotation: float
    z: float
    size: tuple[float, float] = (0.210, 0.297)
    texture: Any = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _finite(self.center, 2, "center"))
        object.__setattr__(self, "size", _finite(self.size, 2, "size"))
        for name in ("rotation", "z"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(float(value)):
                raise InputError(f"Surface.{name} must be a finite number, got {value!r}")
            object.__setattr__(self, name, float(value))
        if min(self.size) <= 0:
            raise InputError(f"Surface.size must be positive, got {self.size}")
        if self.texture is not None:
            tex = np.asarray(self.texture)
            if tex.ndim != 3 or tex.shape[2] != 3 or tex.dtype != np.uint8:
                raise InputError(f"Surface.texture must be an RGB uint8 image (H, W, 3), got {tex.dtype} {tex.shape}")

    def moved(self, center=None, rotation: float | None = None, z: float | None = None) -> "Surface":
        """The same sheet (texture and all) at another pose."""
        return replace(self, center=self.center if center is None else center,
                       rotation=self.rotation if rotation is None else rotation, z=self.z if z is None else z)

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Unit vectors (right, far) in the world frame, each shape (3,), z = 0."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        return np.array([s, -c, 0.0]), np.array([c, s, 0.0])

    def to_world(self, right, far) -> np.ndarray:
        """World points on the surface, shape (3,) or (N, 3), from local (right, far), metres."""
        r_axis, f_axis = self.axes()
        origin = np.array([self.center[0], self.center[1], self.z])
        right = np.asarray(right, dtype=float)
        far = np.asarray(far, dtype=float)
        return origin + right[..., None] * r_axis + far[..., None] * f_axis

    def to_local(self, points) -> np.ndarray:
        """Local (right, far) of world points (..., 3) (or (..., 2)), shape (..., 2); z is ignored."""
        pts = np.asarray(points, dtype=float)
        if pts.shape[-1] not in (2, 3):
            raise InputError(f"expected points of shape (..., 3), got {pts.shape}")
        r_axis, f_axis = self.axes()
        d = pts[..., :2] - np.asarray(self.center)
        if d.ndim == 1:  # one point (a control step's pen tip): the same products, without np.stack
            return np.array([d @ r_axis[:2], d @ f_axis[:2]])
        return np.stack([d @ r_axis[:2], d @ f_axis[:2]], axis=-1)

    def corners(self) -> np.ndarray:
        """The corners on the surface, shape (4, 3), order tl, tr, br, bl."""
        hw, hd = self.size[0] / 2, self.size[1] / 2
        return self.to_world(np.array([-hw, hw, hw, -hw]), np.array([hd, hd, -hd, -hd]))

    def contains(self, points) -> np.ndarray:
        """Boolean (N,): which points (N, 3) lie over the surface, seen from above."""
        local = np.atleast_2d(self.to_local(points))
        return (np.abs(local[:, 0]) <= self.size[0] / 2) & (np.abs(local[:, 1]) <= self.size[1] / 2)

    def touching(self, points) -> np.ndarray:
        """Boolean (N,): which pen-tip points (N, 3) touch the surface (over it, at most
        :data:`CONTACT_TOLERANCE` above it or below it)."""
        points = np.atleast_2d(np.asarray(points, dtype=float))
        return self.contains(points) & (points[:, 2] <= self.z + CONTACT_TOLERANCE)

    def world_T_surface(self) -> np.ndarray:
        """Pose (4, 4) of the surface frame (x = right, y = far, z up) at its centre."""
        right, far = self.axes()
        T = np.eye(4)
        T[:3, 0], T[:3, 1], T[:3, 2] = right, far, np.cross(right, far)
        T[:3, 3] = (self.center[0], self.center[1], self.z)
        return T


@dataclass(frozen=True)
class Scene:
    """What a world asks a simulating back end to build.

    Attributes
    ----------
    surface : Surface or None
        The drawing surface (the paper); None: the back end's default blank sheet.
    home : array_like (3,) or None
        Where the hand starts (metres, world frame); None: the back end decides.
    """

    surface: Surface | None = None
    home: Any = None
