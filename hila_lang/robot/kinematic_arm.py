"""The arm as its robot description gives it, with no simulator: what a back end that drives a real
arm needs to know of the robot -- joint names, forward and inverse kinematics, limits, postures,
speed caps -- behind one small class, :class:`KinematicArm`.

The ROS 2 back end (:mod:`hila_lang.ros`) and its simulated arm (``hila robot-sim``) know the robot
only through this class.  :func:`from_spec` builds it from any :class:`~.spec.RobotSpec` (the
iCub, the Panda, the KUKA, a spec file, a bare URDF): the spec's chain to the pen's tip, its IK
limits (:data:`~.arm.LIMIT_MARGIN` inside the URDF's, within the spec's comfort ranges), joint
weights, seed and rest postures and reach -- exactly what the PyBullet arm (:mod:`.arm`) plans
with -- and the speed caps below.

Speed caps, the rule. A joint's velocity cap is its URDF ``<limit velocity>``, unless that is a
placeholder: not positive, or above :data:`PLACEHOLDER_VELOCITY` (2 pi rad/s, a turn a second,
more than twice the Panda's fastest joint, 2.61 rad/s, which its URDF gives as its datasheet
does); the iCub's URDF says 50000 and pybullet_data's iiwa 10, neither the arm's. A placeholder
becomes :data:`DEFAULT_VELOCITY` (a genuine figure above 2 pi is capped too: on the safe side; a
``<limit>`` without one gets :meth:`~.spec.RobotSpec.limits`' 2 rad/s). A URDF gives no
accelerations, so every joint of every arm gets :data:`ACCELERATION_CAP`, the lowest of the
Panda's published joint limits (7.5-20 rad/s^2: joint 2).

Measured (``python bench/ros_caps.py``: every move of ``programs/reach_return.hila`` and
``programs/game.hila`` planned for each robot at the pen speeds, 0.15 m/s up, 0.05 m/s down,
0.5 m/s^2, with no joint cap):

- fastest joint: iCub 0.47 rad/s, Panda 0.45, KUKA 0.34, so the velocity caps (1 rad/s and
  more) never slow a shipped program;
- largest joint acceleration: reach_return iCub 9.3 rad/s^2, Panda 1.7, KUKA 1.3; game 28.6,
  25.9, 23.4, each where the path turns a corner between two waypoints 2 mm apart (the game's
  reach, 116-119 degrees; the KUKA's retract).  The cap stretches those moves' timing by
  sqrt(peak / 7.5): 6 of the game's 11 moves by up to 1.95 (iCub), 1.86 (Panda), 1.77 (KUKA),
  and 2 of reach_return's 10 on the iCub by up to 1.11.

Frames and units: world frame, metres, radians; ``q`` in the order of :attr:`KinematicArm.joints`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import ik
from .arm import accept, LIMIT_MARGIN

#: a URDF joint velocity above this is a placeholder, not the arm's, rad/s
PLACEHOLDER_VELOCITY = 2 * math.pi
#: the speed cap of a joint whose URDF velocity is a placeholder, rad/s
DEFAULT_VELOCITY = 1.0
#: every joint's acceleration cap (a URDF gives none), rad/s^2
ACCELERATION_CAP = 7.5


@dataclass(frozen=True)
class KinematicArm:
    """One robot's arm: a chain from the world to the tool, and what may move it.

    Attributes
    ----------
    robot : str
        Its name (the spec's).
    chain : ik.KinematicChain
        World to tool tip; its joint names are :attr:`joints`.
    lower, upper : ndarray (n,)
        The URDF's joint limits, radians: no trajectory leaves them.
    ik_lower, ik_upper : ndarray (n,)
        The limits the IK keeps within (a margin inside ``lower``/``upper``), radians.
    weights : ndarray (n,)
        Relative willingness of each joint to move in the IK.
    velocity, acceleration : ndarray (n,)
        Joint speed caps, rad/s and rad/s^2 (:func:`speed_caps`).
    seed : ndarray (n,)
        A posture with the tool in front of the robot, where a first IK starts.
    rest : ndarray (n,)
        The tool out of the way.
    tool_axis : tuple or None
        The direction the tool's +z must point, world frame (the pen down), or None: free.
    reach : ((x, y, z), radius)
        A ball holding every point the tool can reach, metres.
    spec : RobotSpec
        The description it was built from (a simulator loads the same robot).
    """

    robot: str
    chain: ik.KinematicChain
    lower: np.ndarray
    upper: np.ndarray
    ik_lower: np.ndarray
    ik_upper: np.ndarray
    weights: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    seed: np.ndarray
    rest: np.ndarray
    tool_axis: tuple | None
    reach: tuple
    spec: object = None

    @property
    def joints(self) -> tuple[str, ...]:
        """The joint names, root to tool."""
        return self.chain.names

    @property
    def dof(self) -> int:
        return self.chain.dof

    def tip(self, q: np.ndarray) -> np.ndarray:
        """Forward kinematics: the tool tip (3,) at joint angles ``q`` (n,)."""
        return self.chain.tip_position(np.asarray(q, dtype=float))

    def tips(self, qs: np.ndarray) -> np.ndarray:
        """The tool tip (M, 3) at each row of ``qs`` (M, n)."""
        return self.chain.tip_positions(qs)

    def solve(self, target: np.ndarray, q0: np.ndarray) -> ik.IKResult:
        """IK: the tool tip at ``target`` (3,) (and along :attr:`tool_axis`), warm-started at ``q0``;
        ``converged`` judged by the arm's own thresholds (:func:`hila_lang.robot.arm.accept`)."""
        return accept(ik.solve(self.chain, target, q0, lower=self.ik_lower, upper=self.ik_upper,
                               pen_axis=self.tool_axis, weights=self.weights))

    def posture_at(self, point: np.ndarray) -> np.ndarray | None:
        """Joint angles (n,) with the tool tip at ``point`` (3,) from :attr:`seed`, or None."""
        result = self.solve(np.asarray(point, dtype=float), self.seed)
        return result.q if result.converged else None


def speed_caps(urdf_velocity) -> tuple[np.ndarray, np.ndarray]:
    """The joints' caps from their URDF velocities (n,), rad/s (the module docstring's rule):
    (velocity caps (n,) rad/s, acceleration caps (n,) rad/s^2)."""
    v = np.asarray(urdf_velocity, dtype=float)
    placeholder = ~np.isfinite(v) | (v <= 0) | (v > PLACEHOLDER_VELOCITY)
    return np.where(placeholder, DEFAULT_VELOCITY, v), np.full(len(v), ACCELERATION_CAP)


def from_spec(spec) -> KinematicArm:
    """The :class:`KinematicArm` of the robot ``spec`` (a :class:`~.spec.RobotSpec`: the pen's tip,
    its IK limits, weights, postures and reach as :class:`~.arm.Arm` plans with them)."""
    chain = spec.chain()
    lo, hi = spec.ik_limits(LIMIT_MARGIN)
    limits = spec.limits()
    velocity, acceleration = speed_caps([limits[n]["velocity"] for n in chain.names])
    return KinematicArm(
        robot=spec.name, chain=chain, lower=chain.lower.copy(), upper=chain.upper.copy(), ik_lower=lo, ik_upper=hi,
        weights=spec.joint_weights(), velocity=velocity, acceleration=acceleration,
        seed=np.clip(spec.posture("seed"), lo, hi), rest=np.clip(spec.posture("rest"), lo, hi),
        tool_axis=(0.0, 0.0, -1.0), reach=spec.reach(), spec=spec)
