"""The iCub's eyes: gaze (neck and eye tilt), eye-camera poses from the head, images.

Implements :class:`hila_lang.plugins.protocols.Eyes`.  Each eye camera is a pinhole at 320x240
with the iCub's calibrated focal length (paper section III.C); the simulated lens has no
distortion.  An image carries what the robot may know when it took it: the intrinsics, the
camera pose and the joint angles of the chain from the world to the eye
(:meth:`Eyes.chain`), from which the pose follows by forward kinematics.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..sim.camera import Camera, CameraImage
from ..sim.scene import _check_point
from . import ik, model

#: iCub eye camera resolution, pixels (paper section III.C: 320x240 at 20 Hz)
EYE_WIDTH, EYE_HEIGHT = 320, 240
#: iCub eye intrinsics at 320x240 (focal length of the iCub's calibrated eyes, ~64 deg
#: horizontal field of view)
ICUB_EYE_K = np.array([[257.34, 0.0, 160.0], [0.0, 257.34, 120.0], [0.0, 0.0, 1.0]])
#: how much each head joint takes of a gaze change (neck first, then the eyes' tilt)
GAZE_WEIGHTS = {"neck_pitch": 1.0, "neck_yaw": 1.0, model.EYES_TILT_JOINT: 0.3}


def _check_eye(eye: str) -> str:
    if eye not in model.EYE_LINKS:
        raise InputError(f"eye must be 'left' or 'right', got {eye!r}")
    return eye


class Eyes:
    """The two eye cameras of ``body``, looking at ``target`` until told otherwise.

    ``render(camera, shadow=False) -> RGB`` renders the scene the body is in.
    """

    def __init__(self, body, target: np.ndarray, render) -> None:
        self.body, self.render = body, render
        self._gaze_chain = body.chain_to("eyes_tilt_link")
        self._chains: dict[str, ik.KinematicChain] = {}
        self.target = _check_point(target)
        self.look_at(self.target)

    def look_at(self, point: np.ndarray) -> float:
        """Aim the head (neck pitch/yaw, then eyes tilt) at ``point`` (3,); returns the angle
        (radians) still missing when the joints' limits stop it.  The cameras keep looking there.

        The aim starts from the head straight ahead (whatever it looked at before) and is set
        exactly, so the head's angles depend only on the torso and ``point``."""
        target = _check_point(point)
        names = self._gaze_chain.names
        arm = self.body.angles([n for n in names if n in model.ARM_CHAIN])
        q0 = np.array([arm.get(n, 0.0) for n in names])
        weights = np.array([GAZE_WEIGHTS.get(n, 0.0) for n in names])
        q, angle = ik.aim(self._gaze_chain, q0, target, weights)
        for name, value in zip(names, q):
            if name in self.body.held:
                self.body.set_held(name, value)
        self.body.hold_head()
        self.target = target
        return angle

    def chain(self, eye: str = "left") -> ik.KinematicChain:
        """The kinematic chain from the world to ``eye``'s camera frame (OpenCV convention)."""
        _check_eye(eye)
        if eye not in self._chains:
            self._chains[eye] = self.body.chain_to(model.EYE_LINKS[eye])
        return self._chains[eye]

    def camera_pose(self, eye: str = "left") -> np.ndarray:
        """``world_T_camera`` (4, 4) of an eye camera now (OpenCV convention)."""
        return self.body.link_pose(model.EYE_LINKS[_check_eye(eye)])

    def camera_image(self, eye: str = "left", *, shadow: bool = False) -> CameraImage:
        """The ``eye`` camera's image (240, 320, 3) with its intrinsics, pose and joint angles.

        The head first re-aims at the gaze target (the surface's centre unless :meth:`look_at`
        was told otherwise), since the torso may have moved.
        """
        _check_eye(eye)
        self.look_at(self.target)
        camera = Camera(ICUB_EYE_K, self.camera_pose(eye), EYE_WIDTH, EYE_HEIGHT)
        joints = self.body.angles(self.chain(eye).names)
        return CameraImage(self.render(camera, shadow=shadow), camera.K.copy(), camera.world_T_camera.copy(),
                           EYE_WIDTH, EYE_HEIGHT, joints)
