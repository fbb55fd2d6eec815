"""The iCub's stereo eye cameras: their true intrinsics, frame rate, and a pair of them.

The iCub's cameras run at 320x240 and 20 Hz (paper section III.C).  :data:`EYE_K` is the true
(ideal pinhole) intrinsics of both simulated eyes -- the game's and the demonstration's -- with
the lens of :mod:`hila_lang.perception.distortion` in front: what the renderer uses.  The
pipeline does *not* read them: it calibrates each camera from chessboard images
(:mod:`hila_lang.perception.calibration`).  Where the eyes are comes from the robot's head and
eye joint angles through its kinematic chain (:func:`hila_lang.robot.eyes.eye_pose`; the
demonstration's :func:`hila_lang.worlds.tictactoe.recording.demonstration_rig` aims the robot's
gaze at the demonstration sheet with it), never from a look-at guess.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sim.camera import Camera

WIDTH, HEIGHT = 320, 240
#: true intrinsics of the simulated eye cameras at 320x240 (the iCub's calibrated focal length,
#: ~64 degrees horizontal field of view): for rendering only
EYE_K = np.array([[257.34, 0.0, 160.0], [0.0, 257.34, 120.0], [0.0, 0.0, 1.0]])
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


def rig(poses: dict, K: np.ndarray = EYE_K) -> StereoRig:
    """A :class:`StereoRig` of two eyes with intrinsics ``K`` at ``poses`` (eye -> world_T_camera)."""
    return StereoRig(*(Camera(np.asarray(K, float), np.asarray(poses[eye], float), WIDTH, HEIGHT)
                       for eye in ("left", "right")))
