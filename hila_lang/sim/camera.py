"""The one camera model: pinhole intrinsics, poses, projection, rays, and PyBullet rendering.

Conventions (OpenCV's, everywhere in hila):

- camera frame: x right, y down, z forward (out of the lens), metres;
- ``world_T_camera`` (4, 4) maps camera-frame points to the world frame (z up, metres);
- pixel (u, v) = (column, row): ``u = fx X/Z + cx``, ``v = fy Y/Z + cy``; the centre of the
  top-left pixel is (0, 0);
- ``K`` (3, 3) = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], pixels.

OpenGL's conventions (y up, z backward) and PyBullet's pixel offsets are converted in
:func:`gl_view_matrix` and :func:`gl_projection_matrix` and nowhere else; :func:`render` is the
one place that asks PyBullet for an image.  Pure numpy except :func:`render`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..core.errors import InputError


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

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) of world points (N, 3); see :func:`project`."""
        return project(points, self.K, self.world_T_camera)

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


@dataclass(frozen=True)
class CameraImage:
    """One image with the camera that took it and what the robot knew when it took it.

    Attributes
    ----------
    rgb : ndarray, shape (height, width, 3), uint8
    K : ndarray, shape (3, 3)
        Intrinsics, pixels.
    world_T_camera : ndarray, shape (4, 4)
        Camera pose (OpenCV camera frame) in the world frame, metres.
    width, height : int
        Image size, pixels.
    joints : mapping joint name -> radians, or None
        The robot's joint angles when the image was taken (an eye image: enough to recompute
        ``world_T_camera`` from the eye's kinematic chain); None for a camera outside the robot.
    dist : tuple of float, or None
        The lens distortion (OpenCV coefficients k1, k2, p1, p2, k3) the image was taken through,
        as far as whoever took it knows it (the robot's eyes: their own calibration, like ``K``);
        None for an ideal pinhole image.  :func:`hila_lang.perception.distortion.undistorted`
        makes the pinhole image.
    """

    rgb: np.ndarray
    K: np.ndarray
    world_T_camera: np.ndarray
    width: int
    height: int
    joints: Mapping[str, float] | None = None
    dist: tuple | None = None

    @property
    def camera(self) -> Camera:
        return Camera(self.K, self.world_T_camera, self.width, self.height)

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) of world points (N, 3); see :func:`project`."""
        return project(points, self.K, self.world_T_camera)


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
    """Ideal (undistorted) pixel coordinates (N, 2) of world points (N, 3).

    Points on or behind the camera's image plane (z <= 0 in the camera frame) come out as NaN.
    """
    pc = world_to_camera(np.atleast_2d(points), world_T_camera)
    uvw = pc @ np.asarray(K, dtype=float).T
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = uvw[:, :2] / uvw[:, 2:3]
    uv[pc[:, 2] <= 0] = np.nan
    return uv


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


def gl_view_matrix(world_T_camera: np.ndarray) -> list[float]:
    """PyBullet view matrix (16 floats, column-major) for an OpenCV-convention camera pose (4, 4).

    OpenGL's camera has +x right, +y up and looks along -z: OpenCV's y and z are flipped.
    """
    gl_T_cv = np.diag([1.0, -1.0, -1.0, 1.0])
    view = gl_T_cv @ np.linalg.inv(np.asarray(world_T_camera, dtype=float))
    return view.T.reshape(-1).tolist()


def gl_projection_matrix(K: np.ndarray, width: int, height: int, near: float = 0.05,
                         far: float = 5.0) -> list[float]:
    """PyBullet projection matrix (16 floats, column-major) that reproduces ``K`` (3, 3) exactly.

    PyBullet's tiny renderer samples pixel columns at integer x (no half-pixel offset) and flips
    rows with an offset of one, so ``cx`` is used as it is and ``cy`` plus one.  Measured with
    rendered spheres, the centroid then matches :func:`project` to < 0.1 px in both the robot's
    eye cameras and the perception renders (``tests/test_robot_backend.py``,
    ``tests/test_perception_camera.py``); the textbook ``+ 0.5`` on both put the image
    (+0.5, -0.5) px off.  ``near`` and ``far`` are the clipping planes, metres.
    """
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    proj = np.array(
        [
            [2 * fx / width, 0.0, 1 - 2 * cx / width, 0.0],
            [0.0, 2 * fy / height, 2 * (cy + 1.0) / height - 1, 0.0],
            [0.0, 0.0, -(far + near) / (far - near), -2 * far * near / (far - near)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )
    return proj.T.reshape(-1).tolist()


@dataclass(frozen=True)
class RenderStyle:
    """How a scene is lit and clipped when rendered (PyBullet's tiny renderer)."""

    light_direction: tuple[float, float, float] = (0.3, -0.2, 1.0)
    ambient: float = 0.8
    diffuse: float = 0.35
    specular: float = 0.05
    near: float = 0.02
    far: float = 5.0
    shadow: bool = False


def render(pb, client: int, camera: Camera, style: RenderStyle = RenderStyle()) -> np.ndarray:
    """The RGB image (height, width, 3) uint8 of ``camera`` in PyBullet client ``client``."""
    _, _, rgba, _, _ = pb.getCameraImage(
        camera.width, camera.height,
        viewMatrix=gl_view_matrix(camera.world_T_camera),
        projectionMatrix=gl_projection_matrix(camera.K, camera.width, camera.height, style.near, style.far),
        renderer=pb.ER_TINY_RENDERER, shadow=int(style.shadow), lightDirection=list(style.light_direction),
        lightAmbientCoeff=style.ambient, lightDiffuseCoeff=style.diffuse, lightSpecularCoeff=style.specular,
        flags=pb.ER_NO_SEGMENTATION_MASK, physicsClientId=client)
    return np.ascontiguousarray(np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)[:, :, :3])


#: lighting of scenes rendered without a robot (the demonstration recording, chessboard views)
STUDIO = RenderStyle(light_direction=(0.3, 0.2, 1.0), ambient=0.75, diffuse=0.3, specular=0.0, near=0.05)
