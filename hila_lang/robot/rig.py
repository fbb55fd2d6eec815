"""Eyes for an arm without a head: two cameras on a stand beside the table.

:class:`RigEyes` implements :class:`hila_lang.plugins.protocols.Eyes` as the iCub's eyes do
(:mod:`.eyes`), with the same lens model and the robot's own calibration of it:

- ``rgb``: rendered through the simulated fish-eye lens (:func:`.lens.true_lens`: the eyes'
  true intrinsics and distortion, 320x240) at the camera's pose, with seeded Gaussian sensor
  noise when :attr:`RigEyes.noise` is set (``--set eyes.noise=SIGMA``);
- ``K`` and ``dist``: the robot's calibration of the lens (:func:`.lens.eye_calibration`: the
  same lens model as the iCub's eyes, calibrated from chessboard images the same way);
  :meth:`RigEyes.stereo` is its calibration of the pair on this stand
  (:func:`.lens.pair_calibration`, made once per rig geometry and cached);
- ``world_T_camera``: the mount's pose as the spec declares it (:class:`~.spec.RigSpec`: the
  left camera's centre, the point both look at, the baseline to the right camera).  The rig
  has no joints: :meth:`RigEyes.chain` is a fixed chain and ``joints`` is empty, and
  :meth:`RigEyes.look_at` cannot turn it (it only says how far off the point is).

Where a rig stands by default (:data:`hila_lang.robot.spec.RIG_OFFSET`): on the robot's side of the table and
to its left, 0.25 m behind the sheet's centre, 0.30 m to its left and 0.50 m above it, looking
down at it 52 degrees from the horizontal from 0.63 m (the iCub's eyes see the sheet from 0.4 m,
50 degrees), with a 0.10 m baseline.  Measured on the game's board with the Panda and the KUKA
(the pen ready above the sheet's centre, and taken aside): from there both cameras read the
whole grid in all 8 images; from across the table (the sheet's centre + (0.26, 0, 0.44)) the
bright floor beyond the table's front edge was taken for the paper in 2 of the Panda's 4 images;
from (-0.20, 0.25, 0.50) the arm hid one cell in one of each arm's 4.  The arm comes in from the
robot's base, so it hides the board only near the hand.  The stand (a grey pole and bar) is
drawn behind the cameras, out of their view.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import InputError
from ..core.rotation import about_z, pose
from ..sim.camera import CameraImage, look_at
from ..sim.scene import check_point
from . import ik
from .lens import eye_calibration, lens_image, pair_calibration, sensor_window, through_lens, true_lens

#: the pen's radius in the body outline, metres (a little wider than the pen)
PEN_OUTLINE = 0.01
STAND_RGBA = (0.35, 0.35, 0.38, 1.0)


def rig_poses(rig) -> dict[str, np.ndarray]:
    """``{"left", "right"} -> world_T_camera`` (4, 4) of a :class:`~.spec.RigSpec`: both cameras
    parallel, looking at ``rig.look_at`` from the left one, the right one ``rig.baseline`` to
    its right (the camera's +x)."""
    left = look_at(np.asarray(rig.position, float), np.asarray(rig.look_at, float))
    right = left.copy()
    right[:3, 3] = left[:3, 3] + rig.baseline * left[:3, 0]
    return {"left": left, "right": right}


def watching_poses(robot, target) -> dict[str, np.ndarray]:
    """``{"left", "right"} -> world_T_camera`` (4, 4) of ``robot``'s eyes (a
    :class:`~.spec.RobotSpec`) while it watches a demonstration at ``target`` (3,), without a
    simulator: the iCub's head aims its gaze there (:func:`.eyes.eye_poses_looking_at`); a rig's
    cameras stay where they stand."""
    if robot.eyes == "head":
        # lazy: only this branch needs it
        from .eyes import eye_poses_looking_at

        return eye_poses_looking_at(target)
    if robot.eyes is None:
        raise InputError(f"robot {robot.name!r} has no eyes to watch a demonstration with")
    return rig_poses(robot.eyes)


def _fixed_chain(world_T_camera: np.ndarray) -> ik.KinematicChain:
    empty = np.zeros(0)
    return ik.KinematicChain((), np.zeros((0, 4, 4)), np.zeros((0, 3)), np.asarray(world_T_camera, float).copy(),
                             empty, empty)


def _check_eye(eye: str) -> str:
    if eye not in ("left", "right"):
        raise InputError(f"eye must be 'left' or 'right', got {eye!r}")
    return eye


class RigEyes:
    """The two cameras of ``rig`` (a :class:`~.spec.RigSpec`) watching ``body``'s arm in ``sim``
    (see the module docstring).  ``render(camera, shadow=False) -> RGB`` renders the scene."""

    def __init__(self, body, rig, target, render, sim=None, *, noise: float = 0.0, seed: int = 0) -> None:
        self.body, self.rig, self.render = body, rig, render
        self.poses = rig_poses(rig)
        self._chains = {eye: _fixed_chain(p) for eye, p in self.poses.items()}
        self._lens = None
        self.noise = float(noise)
        self._rng = np.random.default_rng([int(seed), 14])
        self.target = check_point(target)
        if sim is not None:
            self._build_stand(sim)

    def _build_stand(self, sim) -> None:
        """A pole from the floor to the cameras and a bar across them, behind the lenses."""
        left, right = self.poses["left"][:3, 3], self.poses["right"][:3, 3]
        back = -self.poses["left"][:3, 2]
        back = back / max(np.linalg.norm(back[:2]), 1e-9) * 0.04
        middle = (left + right) / 2 + [back[0], back[1], 0.0]
        sim.add_box([0.015, 0.015, middle[2] / 2], [middle[0], middle[1], middle[2] / 2 - 0.02], STAND_RGBA)
        half = float(np.linalg.norm(right - left)) / 2 + 0.03
        axis = (right - left) / max(np.linalg.norm(right - left), 1e-9)
        bar = sim.add_box([half, 0.015, 0.015], middle, STAND_RGBA)

        sim.set_pose(bar, pose(about_z(float(np.arctan2(axis[1], axis[0]))), middle))

    def look_at(self, point) -> float:
        """The rig cannot turn: remember ``point`` (3,) as the gaze target and return the angle
        (radians) between the left camera's axis and the direction to it."""
        target = check_point(point)
        self.target = target
        pose = self.poses["left"]
        d = target - pose[:3, 3]
        d /= np.linalg.norm(d)
        return float(np.arccos(np.clip(d @ pose[:3, 2], -1.0, 1.0)))

    def chain(self, eye: str = "left") -> ik.KinematicChain:
        """The fixed chain from the world to ``eye``'s camera frame (no joints)."""
        return self._chains[_check_eye(eye)]

    def joints(self, eye: str = "left") -> dict[str, float]:
        """No joints: ``{}``."""
        _check_eye(eye)
        return {}

    def camera_pose(self, eye: str = "left") -> np.ndarray:
        """``world_T_camera`` (4, 4) of a camera, as the mount places it."""
        return self.poses[_check_eye(eye)].copy()

    def true_pose(self, eye: str = "left") -> np.ndarray:
        """``world_T_camera`` (4, 4) of a camera as the simulator has it (the mount is as declared)."""
        return self.camera_pose(eye)

    def calibration(self, eye: str = "left"):
        """The robot's own calibration of ``eye``'s lens (:func:`.lens.eye_calibration`)."""
        return eye_calibration(_check_eye(eye))

    def stereo(self):
        """The robot's calibration of the pair on this stand (``right_T_left``, :func:`.lens.pair_calibration`)."""
        left_T_right = np.linalg.inv(self.poses["left"]) @ self.poses["right"]
        return pair_calibration(tuple(map(tuple, left_T_right.tolist())), "the stereo rig's camera pair")

    def body_outline(self) -> list[tuple[np.ndarray, float]]:
        """Where the arm is, as its joint angles place it: capsules ``(points (2, 3), radius)``
        between successive joint origins and on to the pen's base (the spec's
        ``outline_radius``), and along the pen (:data:`PEN_OUTLINE`)."""
        chain = self.body.arm_chain
        tip, joints, _ = chain.forward(self.body.arm_angles())
        spec = self.body.spec
        base = tip[:3, 3] - spec.pen_length * tip[:3, 2]
        points = [*joints, base]
        radius = float(spec.outline_radius)
        out = [(np.array([a, b]), radius) for a, b in zip(points[:-1], points[1:])]
        return out + [(np.array([base, tip[:3, 3]]), PEN_OUTLINE)]

    def camera_image(self, eye: str = "left", *, shadow: bool = False, region=None) -> CameraImage:
        """The camera's image (240, 320, 3) through its lens, with what the robot knows of it: its
        calibration (``K``, ``dist``) and the mount's pose (no joints); ``region`` (N, 3): only
        the sensor's part that sees those points, as :meth:`.eyes.Eyes.camera_image`."""
        pose = self.poses[_check_eye(eye)]
        if self._lens is None:
            self._lens = true_lens(1)
        calib = self.calibration(eye)
        window = None if region is None else sensor_window(region, calib, pose)
        rgb = through_lens(self._lens, self.render, pose, window, shadow)
        if self.noise > 0:
            rgb = np.clip(rgb + self._rng.normal(0.0, self.noise, rgb.shape), 0, 255).astype(np.uint8)
        return lens_image(rgb, calib, pose, {}, window)
