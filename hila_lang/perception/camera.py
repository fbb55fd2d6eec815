"""Pinhole cameras: intrinsics, poses, projection and PyBullet view/projection matrices.

Conventions (OpenCV's, used everywhere in :mod:`hila_lang.perception`):

- camera frame: x right, y down, z forward (out of the lens), metres;
- ``world_T_camera`` (4, 4) maps camera-frame points to the world frame (z up, metres);
- pixel (u, v): u to the right, v down, the centre of the top-left pixel is (0, 0);
- ``K`` (3, 3) = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], pixels.

OpenGL conventions (y up, z backward, PyBullet's pixel offsets) are converted in
:func:`hila_lang.robot.cameras.gl_view_matrix` and :func:`~hila_lang.robot.cameras.gl_projection_matrix`
and nowhere else (re-exported here).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..robot.cameras import gl_projection_matrix, gl_view_matrix  # noqa: F401  (re-exported)


@dataclass(frozen=True)
class Camera:
    """A pinhole camera without distortion.

    Attributes
    ----------
    K : ndarray, shape (3, 3)
        Intrinsics, pixels.
    world_T_camera : ndarray, shape (4, 4)
        Pose of the camera frame (x right, y down, z forward) in the world frame, metres.
    width, height : int
        Image size, pixels.
    """

    K: np.ndarray
    world_T_camera: np.ndarray
    width: int
    height: int

    def with_size(self, width: int, height: int, scale: float = 1.0) -> "Camera":
        """The same camera with a canvas of ``width`` x ``height`` centred on the same axis.

        ``scale`` multiplies the focal length (2 renders at twice the resolution).
        """
        K = self.K.copy()
        K[0, 0] *= scale
        K[1, 1] *= scale
        K[0, 2] = (self.K[0, 2] + 0.5) * scale - 0.5 + (width - self.width * scale) / 2
        K[1, 2] = (self.K[1, 2] + 0.5) * scale - 0.5 + (height - self.height * scale) / 2
        return Camera(K, self.world_T_camera, int(width), int(height))


def intrinsics(width: int, height: int, hfov_deg: float) -> np.ndarray:
    """K (3, 3) of a centred camera with square pixels and horizontal field of view ``hfov_deg``."""
    f = (width / 2.0) / np.tan(np.radians(hfov_deg) / 2.0)
    return np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0], [0.0, 0.0, 1.0]])


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """``world_T_camera`` (4, 4) of a camera at ``eye`` looking at ``target`` (world, metres).

    The image's "up" is as close to ``up`` as possible.  Raises :class:`InputError` when the
    viewing direction is parallel to ``up`` or ``eye == target``.
    """
    eye = np.asarray(eye, dtype=float)
    z = np.asarray(target, dtype=float) - eye
    n = np.linalg.norm(z)
    if n < 1e-12:
        raise InputError("camera eye and target coincide")
    z /= n
    x = np.cross(z, np.asarray(up, dtype=float))
    if np.linalg.norm(x) < 1e-9:
        raise InputError("camera looks along its 'up' vector; choose another up")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, y, z, eye
    return T


def world_to_camera(points: np.ndarray, world_T_camera: np.ndarray) -> np.ndarray:
    """Points (N, 3) in the world frame -> (N, 3) in the camera frame, metres."""
    R, t = world_T_camera[:3, :3], world_T_camera[:3, 3]
    return (np.asarray(points, dtype=float) - t) @ R


def project(points: np.ndarray, K: np.ndarray, world_T_camera: np.ndarray) -> np.ndarray:
    """Ideal (undistorted) pixel coordinates (N, 2) of world points (N, 3)."""
    pc = world_to_camera(np.atleast_2d(points), world_T_camera)
    uvw = pc @ np.asarray(K, dtype=float).T
    return uvw[:, :2] / uvw[:, 2:3]


def pixel_rays(uv: np.ndarray, K: np.ndarray, world_T_camera: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rays through ideal pixels ``uv`` (N, 2): origin (3,) and unit directions (N, 3), world."""
    uv = np.atleast_2d(np.asarray(uv, dtype=float))
    hom = np.column_stack([uv, np.ones(len(uv))])
    d_cam = hom @ np.linalg.inv(K).T
    d = d_cam @ world_T_camera[:3, :3].T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return world_T_camera[:3, 3].copy(), d


def intersect_plane_z(uv: np.ndarray, K: np.ndarray, world_T_camera: np.ndarray, z: float) -> np.ndarray:
    """World points (N, 3) where the rays through ideal pixels ``uv`` (N, 2) meet the plane z."""
    o, d = pixel_rays(uv, K, world_T_camera)
    s = (z - o[2]) / d[:, 2]
    return o + s[:, None] * d
