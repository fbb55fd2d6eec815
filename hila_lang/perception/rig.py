"""The iCub's stereo eye cameras while it watches something: intrinsics and poses.

The iCub's eyes are 68 mm apart on its head, about 0.33 m above the waist; its cameras run at
320x240 and 20 Hz (paper section III.C).  While it watches the demonstrator the neck is tilted
down and both eyes verge on the centre of the demonstration grid.  The true (ideal pinhole)
intrinsics here are what the renderer uses; the pipeline does *not* read them: it calibrates
each camera from chessboard images (:mod:`hila_lang.perception.calibration`) and uses the
calibrated intrinsics with the eyes' poses from the head kinematics (``world_T_camera``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sim.camera import Camera, intrinsics, look_at

WIDTH, HEIGHT = 320, 240
#: horizontal field of view of the eye cameras, degrees (f ~ 257 px at 320 px)
HFOV_DEG = 64.0
#: distance between the eyes, metres
BASELINE = 0.068
#: midpoint between the eyes, world frame, metres (root (0, 0, 0.62) + torso + neck)
EYES_CENTER = (0.05, 0.0, 0.95)
#: frame rate of the eye cameras, Hz
FPS = 20.0


@dataclass(frozen=True)
class StereoRig:
    """The left and right eye cameras (true, undistorted pinhole models)."""

    left: Camera
    right: Camera

    def camera(self, eye: str) -> Camera:
        """``"left"`` or ``"right"``."""
        return {"left": self.left, "right": self.right}[eye]


def stereo_rig(target, *, eyes_center=EYES_CENTER, baseline: float = BASELINE, hfov_deg: float = HFOV_DEG,
               width: int = WIDTH, height: int = HEIGHT) -> StereoRig:
    """Eye cameras verging on ``target`` (3,), world, metres.

    The left eye is at +y (the robot's left; it faces +x), the right eye at -y.
    """
    target = np.asarray(target, dtype=float)
    c = np.asarray(eyes_center, dtype=float)
    K = intrinsics(width, height, hfov_deg)
    cams = []
    for sign in (1.0, -1.0):
        eye = c + np.array([0.0, sign * baseline / 2, 0.0])
        cams.append(Camera(K, look_at(eye, target), width, height))
    return StereoRig(*cams)
