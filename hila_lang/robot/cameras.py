"""Pinhole cameras: intrinsics, poses, projection, and rendering through PyBullet.

Convention (everywhere in hila): a camera pose ``world_T_camera`` (4, 4) maps camera
coordinates to world coordinates, and the camera frame is OpenCV's: +z along the optical axis,
+x to the image's right, +y to the image's bottom.  Pixels are (u, v) = (column, row) with
OpenCV's convention: ``u = fx X/Z + cx``, ``v = fy Y/Z + cy``, and the top-left pixel's centre is
(0, 0).  The conversion to
PyBullet's OpenGL view and projection matrices happens in :func:`gl_view_matrix` and
:func:`gl_projection_matrix` and nowhere else (:mod:`hila_lang.perception` renders with them too).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: iCub eye camera resolution, pixels (paper section III.C: 320x240 at 20 Hz)
EYE_WIDTH, EYE_HEIGHT = 320, 240
#: iCub eye intrinsics at 320x240 (focal length of the iCub's calibrated eyes, ~64 deg
#: horizontal field of view); the simulated lens has no distortion
ICUB_EYE_K = np.array([[257.34, 0.0, 160.0], [0.0, 257.34, 120.0], [0.0, 0.0, 1.0]])
#: clipping planes for rendering, metres
NEAR, FAR = 0.02, 5.0


@dataclass(frozen=True)
class CameraImage:
    """One rendered image with the camera that took it.

    Attributes
    ----------
    rgb : ndarray, shape (height, width, 3), uint8
    K : ndarray, shape (3, 3)
        Intrinsics, pixels.
    world_T_camera : ndarray, shape (4, 4)
        Camera pose (OpenCV camera frame) in the world frame, metres.
    width, height : int
        Image size, pixels.
    """

    rgb: np.ndarray
    K: np.ndarray
    world_T_camera: np.ndarray
    width: int
    height: int

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates (N, 2) of world points (N, 3); see :func:`project`."""
        return project(self.K, self.world_T_camera, points)


def project(K: np.ndarray, world_T_camera: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Project world points (N, 3) to pixels (N, 2) as (u, v) = (column, row).

    Points behind the camera come out as NaN.
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    camera_T_world = np.linalg.inv(world_T_camera)
    cam = pts @ camera_T_world[:3, :3].T + camera_T_world[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = (cam @ K.T)[:, :2] / cam[:, 2:3]
    uv[cam[:, 2] <= 0] = np.nan
    return uv


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


def render(
    client: int,
    K: np.ndarray,
    world_T_camera: np.ndarray,
    width: int,
    height: int,
    *,
    shadow: bool = False,
) -> CameraImage:
    """Render the PyBullet world of ``client`` through a pinhole camera (tiny renderer).

    Parameters
    ----------
    client : int
        PyBullet physics client id.
    K : ndarray, shape (3, 3)
    world_T_camera : ndarray, shape (4, 4)
        OpenCV-convention camera pose, world frame.
    width, height : int
        Pixels.
    """
    from .console import import_pybullet

    pb = import_pybullet()

    _, _, rgba, _, _ = pb.getCameraImage(
        width,
        height,
        viewMatrix=gl_view_matrix(world_T_camera),
        projectionMatrix=gl_projection_matrix(K, width, height, NEAR, FAR),
        renderer=pb.ER_TINY_RENDERER,
        shadow=int(shadow),
        lightDirection=[0.3, -0.2, 1.0],
        lightAmbientCoeff=0.8,
        lightDiffuseCoeff=0.35,
        lightSpecularCoeff=0.05,
        physicsClientId=client,
    )
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()
    return CameraImage(rgb, np.array(K, dtype=float), np.array(world_T_camera, dtype=float), width, height)
