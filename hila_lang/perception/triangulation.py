"""Stereo triangulation: two cameras' pixel tracks -> a 3-D path in the world frame.

The intrinsics come from calibration; the cameras' poses (``world_T_camera``) from the robot's
head kinematics at the time of recording.  Pixels must be *undistorted* first
(:func:`hila_lang.perception.distortion.undistort_points` with the calibrated coefficients).
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from ..sim.camera import project


def projection_matrix(K: np.ndarray, world_T_camera: np.ndarray) -> np.ndarray:
    """P (3, 4) = K [R | t] mapping homogeneous world points to homogeneous pixels."""
    camera_T_world = np.linalg.inv(np.asarray(world_T_camera, dtype=float))
    return np.asarray(K, dtype=float) @ camera_T_world[:3, :]


def triangulate(uv_left: np.ndarray, uv_right: np.ndarray, K_left: np.ndarray, world_T_left: np.ndarray,
                K_right: np.ndarray, world_T_right: np.ndarray) -> np.ndarray:
    """World points (N, 3), metres, from ideal pixel pairs ``uv_left``, ``uv_right`` (N, 2).

    Linear triangulation (``cv2.triangulatePoints``, DLT).

    Raises
    ------
    InputError
        The two tracks differ in length, or a point lands behind a camera.
    """
    # lazy: loads cv2, which importing this module does not
    import cv2

    a = np.atleast_2d(np.asarray(uv_left, dtype=float))
    b = np.atleast_2d(np.asarray(uv_right, dtype=float))
    if a.shape != b.shape or a.shape[1] != 2:
        raise InputError(f"expected two pixel tracks of the same shape (N, 2), got {a.shape} and {b.shape}")
    Pl = projection_matrix(K_left, world_T_left)
    Pr = projection_matrix(K_right, world_T_right)
    X = cv2.triangulatePoints(Pl, Pr, a.T.copy(), b.T.copy())
    pts = (X[:3] / X[3]).T
    for name, T in (("left", world_T_left), ("right", world_T_right)):
        depth = (pts - T[:3, 3]) @ T[:3, 2]
        if (depth <= 0).any():
            bad = np.flatnonzero(depth <= 0)[:8].tolist()
            raise InputError(f"triangulated points {bad} lie behind the {name} camera: "
                             "are the left and right images swapped?")
    return pts


def reprojection_error(points: np.ndarray, uv: np.ndarray, K: np.ndarray, world_T_camera: np.ndarray) -> np.ndarray:
    """Distance (N,), pixels, between ``uv`` (N, 2) and the projections of ``points`` (N, 3)."""
    return np.linalg.norm(project(points, K, world_T_camera) - uv, axis=1)
