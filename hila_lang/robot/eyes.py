"""The iCub's eyes: gaze (neck and eye tilt), eye-camera poses from the joint angles, images.

Implements :class:`hila_lang.plugins.protocols.Eyes`.  An eye image is what the robot's sensor
gives and what the robot knows about it, and nothing of the simulator's truth:

- ``rgb``: rendered through the simulated fish-eye lens (:mod:`.lens`: the true intrinsics and
  distortion, 320x240), at the eye's true pose in the simulator, with seeded Gaussian sensor
  noise when :attr:`Eyes.noise` is set (``--set eyes.noise=SIGMA``, grey levels);
- ``K`` and ``dist``: the robot's own calibration of that lens (:func:`.lens.eye_calibration`,
  chessboard images through the OpenCV pipeline, made once and cached; :meth:`Eyes.stereo`
  is its calibration of the eye pair, for triangulating);
- ``world_T_camera``: from the head and eye joint angles through the eye's kinematic chain
  (:func:`eye_pose`, the one function that places an eye; the same joint angles are in
  ``joints``).  The simulator's link pose is used to render only.

:func:`hila_lang.perception.distortion.undistorted` turns an image into the pinhole image the
board reader works on.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ..core.errors import InputError
from ..core.rotation import about_z, pose
from ..sim.camera import CameraImage
from ..sim.scene import check_point
from . import ik, model
from .lens import eye_calibration, EYE_HEIGHT, EYE_WIDTH, eyes_calibration, ICUB_EYE_K, lens_image, sensor_window, through_lens, true_lens

__all__ = ["EYE_HEIGHT", "EYE_WIDTH", "Eyes", "ICUB_EYE_K", "aim_gaze", "eye_pose", "eye_poses_looking_at"]

#: how much each head joint takes of a gaze change (neck first, then the eyes' tilt)
GAZE_WEIGHTS = {"neck_pitch": 1.0, "neck_yaw": 1.0, model.EYES_TILT_JOINT: 0.3}
#: the right arm as the robot's eyes allow for it, capsules between the chain's joints (indices
#: into ``model.ARM_CHAIN``; "palm" is the pen's base, "tip" its tip, "fingers" and "thumb" 6
#: and 7.5 cm from the palm along the hand frame's +x and -y, as the hand's mesh reaches) with
#: radii in metres: the iCub's upper arm, forearm and hand are about 0.035, 0.03 and 0.04 m
#: thick (radius), taken 1 cm wider so that nothing of the arm is read as ink
ARM_OUTLINE = (((3, 6), 0.045), ((6, 8), 0.04), ((8, "palm"), 0.05), (("palm", "fingers"), 0.05),
               (("palm", "thumb"), 0.035), (("palm", "tip"), 0.01))
#: the simulated lens renders at this many times the resolution, then averages down; measured:
#: 1x reads the game board's corners within 0.08 mm of 2x at 40 % of the time (96 vs 234 ms)
LENS_SUPERSAMPLE = 1


def _check_eye(eye: str) -> str:
    if eye not in model.EYE_LINKS:
        raise InputError(f"eye must be 'left' or 'right', got {eye!r}")
    return eye


def eye_pose(chain: ik.KinematicChain, joints: Mapping[str, float]) -> np.ndarray:
    """``world_T_camera`` (4, 4) of an eye from joint angles (name -> radians) through its
    kinematic chain (:meth:`Eyes.chain`): the one place an eye camera is placed, for the gaze,
    for every image and for whoever reads an image's ``joints`` again."""
    try:
        q = np.array([float(joints[name]) for name in chain.names])
    except KeyError as exc:
        raise InputError(f"joint angles lack {exc.args[0]!r}, a joint of the eye's chain") from None
    return chain.forward(q)[0]


def aim_gaze(chain: ik.KinematicChain, torso: Mapping[str, float], target: np.ndarray) -> tuple[np.ndarray, float]:
    """Joint angles (n,) of the gaze ``chain`` (world to the eyes' tilt link) that aim the eyes at
    ``target`` (3,), neck first then the eyes' tilt (:data:`GAZE_WEIGHTS`), from the head straight
    ahead with the torso at ``torso`` (name -> radians; joints not given at 0); and the angle,
    radians, still missing where the joints' limits stop it."""
    weights = np.array([GAZE_WEIGHTS.get(n, 0.0) for n in chain.names])
    q0 = np.array([float(torso.get(n, 0.0)) for n in chain.names])
    return ik.aim(chain, q0, np.asarray(target, dtype=float), weights)


def eye_poses_looking_at(target: np.ndarray, torso: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
    """``{"left", "right"} -> world_T_camera`` (4, 4) of the eyes when the robot (torso at
    ``torso``, default upright) looks at ``target`` (3,): :func:`aim_gaze` and :func:`eye_pose`
    on the robot's own model, without a simulator -- where its eyes are while it watches a
    demonstration (:func:`hila_lang.worlds.tictactoe.recording.demonstration_rig`)."""
    text = model.urdf_path().read_text()
    root = pose(about_z(model.ROOT_YAW), model.ROOT_POSITION)
    gaze = ik.KinematicChain.from_urdf(text, "eyes_tilt_link", root)
    q, _ = aim_gaze(gaze, torso or {}, check_point(target))
    joints = dict(zip(gaze.names, q))
    return {eye: eye_pose(ik.KinematicChain.from_urdf(text, model.EYE_LINKS[eye], root), joints)
            for eye in ("left", "right")}


class Eyes:
    """The two eye cameras of ``body``, looking at ``target`` until told otherwise.

    ``render(camera, shadow=False) -> RGB`` renders the scene the body is in.

    Attributes
    ----------
    noise : float
        Standard deviation of the sensor noise added to every image, grey levels (0: none).
    """

    def __init__(self, body, target: np.ndarray, render, *, noise: float = 0.0, seed: int = 0) -> None:
        self.body, self.render = body, render
        self._gaze_chain = body.chain_to("eyes_tilt_link")
        self._chains: dict[str, ik.KinematicChain] = {}
        self._aims: dict[tuple, tuple[np.ndarray, float]] = {}  # (torso, point) -> aim_gaze's answer
        self._lens = None
        self.noise = float(noise)
        self._rng = np.random.default_rng([int(seed), 14])
        self.target = check_point(target)
        self.look_at(self.target)

    def look_at(self, point: np.ndarray) -> float:
        """Aim the head (neck pitch/yaw, then eyes tilt) at ``point`` (3,); returns the angle
        (radians) still missing when the joints' limits stop it.  The cameras keep looking there.

        The aim starts from the head straight ahead (whatever it looked at before) and is set
        exactly, so the head's angles depend only on the torso and ``point``."""
        target = check_point(point)
        names = self._gaze_chain.names
        torso = self.body.angles([n for n in names if n in model.ARM_CHAIN])
        # the aim depends on nothing else: the same torso and point (a look's second eye, a glance
        # while the torso waits) give the same angles, kept rather than solved again (a quarter of
        # a game's 200 aims, about 1.5 ms each)
        key = (tuple(torso.items()), target.tobytes())
        if key not in self._aims:
            if len(self._aims) >= 64:
                self._aims.clear()
            self._aims[key] = aim_gaze(self._gaze_chain, torso, target)
        q, angle = self._aims[key]
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

    def joints(self, eye: str = "left") -> dict[str, float]:
        """The angles (radians) of the joints of ``eye``'s chain now."""
        return self.body.angles(self.chain(eye).names)

    def camera_pose(self, eye: str = "left") -> np.ndarray:
        """``world_T_camera`` (4, 4) of an eye camera now, from its joint angles (:func:`eye_pose`)."""
        return eye_pose(self.chain(eye), self.joints(eye))

    def true_pose(self, eye: str = "left") -> np.ndarray:
        """``world_T_camera`` (4, 4) of ``eye`` as the simulator has it: truth, for a referee only."""
        return self.body.link_pose(model.EYE_LINKS[_check_eye(eye)])

    def calibration(self, eye: str = "left"):
        """The robot's own calibration of ``eye`` (:func:`.lens.eye_calibration`)."""
        return eye_calibration(_check_eye(eye))

    def body_outline(self) -> list[tuple[np.ndarray, float]]:
        """Where the robot's right arm is, as it knows it (its joint angles through its model):
        capsules ``(points (2, 3) world frame, radius metres)`` from the shoulder to the pen's
        tip (:data:`ARM_OUTLINE`).  A reader of the eyes' images treats what they cover as
        hidden rather than as what is behind it."""
        chain = self.body.arm_chain
        tip, joints, _ = chain.forward(self.body.arm_angles())
        palm = tip[:3, 3] - model.PEN_LENGTH * tip[:3, 2]
        points = {**dict(enumerate(joints)), "tip": tip[:3, 3], "palm": palm,
                  "fingers": palm + 0.06 * tip[:3, 0], "thumb": palm - 0.075 * tip[:3, 1]}
        return [(np.array([points[a], points[b]]), float(r)) for (a, b), r in ARM_OUTLINE]

    def stereo(self):
        """The robot's own calibration of the eye pair (:func:`.lens.eyes_calibration`:
        ``right_T_left``)."""
        return eyes_calibration()

    def camera_image(self, eye: str = "left", *, shadow: bool = False, region=None) -> CameraImage:
        """The ``eye`` camera's image (240, 320, 3) through its lens, with what the robot knows
        of it: its calibration (``K``, ``dist``), its pose from the joint angles and the angles.

        The head first re-aims at the gaze target (the surface's centre unless :meth:`look_at`
        was told otherwise), since the torso may have moved.  ``region`` (N, 3) world points:
        only the part of the sensor that sees them, as the robot's calibration and pose place them
        (:func:`.lens.sensor_window`; a glance at a known thing), is read -- a smaller image whose
        ``K`` says where it lies on the sensor, at a fraction of the cost (the whole image when
        the region is not in view).
        """
        _check_eye(eye)
        self.look_at(self.target)
        joints = self.joints(eye)
        if self._lens is None:
            self._lens = true_lens(LENS_SUPERSAMPLE)
        calib = self.calibration(eye)
        world_T_camera = eye_pose(self.chain(eye), joints)
        window = None if region is None else sensor_window(region, calib, world_T_camera)
        # the simulator's own link pose places the rendering camera: truth, for the picture only
        truth = self.body.link_pose(model.EYE_LINKS[eye])
        rgb = through_lens(self._lens, self.render, truth, window, shadow)
        if self.noise > 0:
            rgb = np.clip(rgb + self._rng.normal(0.0, self.noise, rgb.shape), 0, 255).astype(np.uint8)
        return lens_image(rgb, calib, world_T_camera, joints, window)

