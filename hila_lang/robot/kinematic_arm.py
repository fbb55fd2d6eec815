"""The arm as a description gives it, with no simulator: what a back end that drives a real arm
needs to know of the robot -- joint names, forward and inverse kinematics, limits, postures, speed
caps -- behind one small class, :class:`KinematicArm`.

The ROS 2 back end (:mod:`hila_lang.ros`) and its simulated arm (``hila robot-sim``) know the robot
only through this class.  :func:`for_robot` builds it; today it knows the iCub (the generated URDF
of :mod:`.model`, the torso + right-arm chain to the pen tip, solved as :mod:`.arm` solves it).
A robot described by a URDF and a spec (another arm) is a second branch of :func:`for_robot` that
fills the same fields.

Speed caps.  The iCub URDF's joint velocities (50000) are placeholders, as its efforts are, so
the iCub's caps are :data:`ICUB_VELOCITY` and :data:`ICUB_ACCELERATION`.  Measured on every move
of ``programs/reach_return.hila`` and ``programs/game.hila``, timed at the pen speeds (0.15 m/s up,
0.05 m/s down, 0.5 m/s^2) with no joint cap (:mod:`hila_lang.ros.plan`): the fastest joint turned
at 0.47 rad/s, so the speed cap of 1 rad/s never slows them; the largest joint acceleration was
9.3 rad/s^2 (reach_return) and 28.6 rad/s^2 (game), both where a path turns a corner between two
points 2 mm apart.  The acceleration cap of 10 rad/s^2 leaves reach_return at its pen speeds and
stretches the game's cornering moves by up to 1.7 (sqrt(28.6 / 10)); both caps stay well below
what the iCub's arm motors do.

Frames and units: world frame, metres, radians; ``q`` in the order of :attr:`KinematicArm.joints`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..core.errors import InputError
from . import ik

#: the robots :func:`for_robot` knows
ROBOTS = ("icub",)
#: the iCub's joint speed cap, rad/s (torso, then arm), and acceleration cap, rad/s^2
ICUB_VELOCITY = 1.0
ICUB_ACCELERATION = 10.0


@dataclass(frozen=True)
class KinematicArm:
    """One robot's arm: a chain from the world to the tool, and what may move it.

    Attributes
    ----------
    robot : str
        Its name (``--robot NAME``).
    urdf : str
        The URDF text the chain was read from (a simulator loads the same file).
    chain : ik.KinematicChain
        World to tool tip; its joint names are :attr:`joints`.
    lower, upper : ndarray (n,)
        The URDF's joint limits, radians: no trajectory leaves them.
    ik_lower, ik_upper : ndarray (n,)
        The limits the IK keeps within (a margin inside ``lower``/``upper``), radians.
    weights : ndarray (n,)
        Relative willingness of each joint to move in the IK.
    velocity, acceleration : ndarray (n,)
        Joint speed caps, rad/s and rad/s^2.
    seed : ndarray (n,)
        A posture with the tool in front of the robot, where a first IK starts.
    rest : ndarray (n,)
        The tool out of the way.
    tool_axis : tuple or None
        The direction the tool's +z must point, world frame (the pen down), or None: free.
    reach : ((x, y, z), radius)
        A ball holding every point the tool can reach, metres.
    """

    robot: str
    urdf: str
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
        from .arm import accept

        return accept(ik.solve(self.chain, target, q0, lower=self.ik_lower, upper=self.ik_upper,
                               pen_axis=self.tool_axis, weights=self.weights))

    def posture_at(self, point: np.ndarray) -> np.ndarray | None:
        """Joint angles (n,) with the tool tip at ``point`` (3,) from :attr:`seed`, or None."""
        result = self.solve(np.asarray(point, dtype=float), self.seed)
        return result.q if result.converged else None


def for_robot(name: str = "icub") -> KinematicArm:
    """The :class:`KinematicArm` of robot ``name`` (one of :data:`ROBOTS`); an InputError otherwise."""
    key = str(name).strip().lower()
    if key not in ROBOTS:
        import difflib

        close = difflib.get_close_matches(key, ROBOTS, n=1)
        raise InputError(f"unknown robot {name!r}; known: {', '.join(ROBOTS)}",
                         hint=f"did you mean {close[0]!r}?" if close else None)
    return _icub()


@lru_cache(maxsize=1)
def _icub() -> KinematicArm:
    """The iCub's torso + right arm holding the pen (:mod:`.model`, solved as :mod:`.arm` solves it)."""
    from . import arm, model, reach

    urdf = model.urdf_path().read_text()
    chain = ik.KinematicChain.from_urdf(urdf, model.PEN_TIP_LINK, model.world_T_root())
    lo, hi = arm.comfort_limits(chain)
    n = chain.dof
    return KinematicArm(
        robot="icub", urdf=urdf, chain=chain, lower=chain.lower.copy(), upper=chain.upper.copy(),
        ik_lower=lo, ik_upper=hi, weights=arm.JOINT_WEIGHTS.copy(),
        velocity=np.full(n, ICUB_VELOCITY), acceleration=np.full(n, ICUB_ACCELERATION),
        seed=np.clip(arm.SEED_POSTURE, lo, hi), rest=np.clip(arm.REST_POSTURE, lo, hi),
        tool_axis=(0.0, 0.0, -1.0), reach=(tuple(reach.REACH_CENTRE), float(reach.REACH_RADIUS)))
