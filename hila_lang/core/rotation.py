"""Rotations: one convention, through one library (``scipy.spatial.transform.Rotation``).

- matrices (3, 3) act on column vectors: ``p_A = A_R_B @ p_B``;
- quaternions are ``(x, y, z, w)`` -- scipy's order and PyBullet's, so they cross that boundary
  as they are;
- roll-pitch-yaw is URDF's: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (scipy's extrinsic ``"xyz"``).

The one exception is the forward kinematics' inner loop (:mod:`hila_lang.robot.ik`), which
rotates about joint axes with Rodrigues' formula for speed; ``tests/test_robot_ik.py`` holds it
equal to :func:`from_axis_angle`.
"""

from __future__ import annotations

import warnings

import numpy as np


def _R():
    # lazy: loads scipy, which importing this module does not
    from scipy.spatial.transform import Rotation

    return Rotation


def from_rpy(rpy) -> np.ndarray:
    """URDF (roll, pitch, yaw), radians -> rotation matrix (3, 3)."""
    return _R().from_euler("xyz", np.asarray(rpy, dtype=float)).as_matrix()


def to_rpy(matrix) -> tuple[float, float, float]:
    """Rotation matrix (3, 3) -> URDF (roll, pitch, yaw), radians (pitch in [-pi/2, pi/2])."""
    with warnings.catch_warnings():  # gimbal lock: scipy warns and puts it all in one angle
        warnings.simplefilter("ignore", UserWarning)
        r, p, y = _R().from_matrix(np.asarray(matrix, dtype=float)).as_euler("xyz")
    return float(r), float(p), float(y)


def from_euler(seq: str, angles, degrees: bool = False) -> np.ndarray:
    """Rotation matrix (3, 3) of Euler ``angles`` in scipy's axis sequence ``seq``."""
    return _R().from_euler(seq, angles, degrees=degrees).as_matrix()


def from_axis_angle(axis, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) of ``angle`` radians about the unit ``axis`` (3,)."""
    return _R().from_rotvec(np.asarray(axis, dtype=float) * float(angle)).as_matrix()


def from_quat(xyzw) -> np.ndarray:
    """Quaternion (x, y, z, w) -> rotation matrix (3, 3)."""
    return _R().from_quat(np.asarray(xyzw, dtype=float)).as_matrix()


def to_quat(matrix) -> np.ndarray:
    """Rotation matrix (3, 3) -> quaternion (4,) (x, y, z, w)."""
    return _R().from_matrix(np.asarray(matrix, dtype=float)).as_quat()


def about_z(angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) of ``angle`` radians about +z."""
    return from_euler("z", float(angle))


def pose(rotation=None, translation=None) -> np.ndarray:
    """Homogeneous transform (4, 4) from a rotation (3, 3) and a translation (3,)."""
    out = np.eye(4)
    if rotation is not None:
        out[:3, :3] = rotation
    if translation is not None:
        out[:3, 3] = translation
    return out
