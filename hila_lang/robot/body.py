"""A robot loaded into a :class:`~hila_lang.sim.scene.SimScene` from its spec: joints, links, chains, holding.

:class:`Body` knows the robot's own joints and kinematics -- what the robot may know about
itself -- and talks to PyBullet for them: joint angles, link poses, position-control commands.
"""

from __future__ import annotations

import numpy as np

from ..core.errors import HilaRuntimeError
from ..core.rotation import from_quat, pose, to_quat
from ..sim.client import quiet_c_output
from . import ik


class Body:
    """The robot of ``spec`` (:class:`~.spec.RobotSpec`, default the iCub) fixed at its base in ``sim``.

    Attributes
    ----------
    spec : RobotSpec
    id : int
        PyBullet body id.
    world_T_root : ndarray (4, 4)
        Where the base link stands.
    arm_chain : ik.KinematicChain
        The arm to the pen tip (the iCub: torso + right arm), in the order of ``spec.chain()``.
    held : dict[str, float]
        Other revolute joints position-controlled at these angles (the iCub's neck and eyes;
        its legs and left arm, and any arm's fingers, are fixed in the prepared URDF).
    """

    def __init__(self, sim, spec=None) -> None:
        if spec is None:
            # lazy: only this branch needs it
            from .model import spec as icub

            spec = icub()
        self.sim, self.spec = sim, spec
        pb, c = sim.pb, sim.client
        path = spec.urdf_path()
        self.urdf = path.read_text()
        self.world_T_root = spec.world_T_base()
        with quiet_c_output():
            self.id = pb.loadURDF(str(path), list(spec.base_position), to_quat(self.world_T_root[:3, :3]).tolist(),
                                  useFixedBase=True, flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=c)
        self.arm_chain = self.chain_to(spec.tip_link())
        if self.arm_chain.names != spec.chain().names:
            raise HilaRuntimeError(f"unexpected arm chain in the {spec.name} model: {self.arm_chain.names}")
        self.joint: dict[str, int] = {}
        self.link: dict[str, int] = {}
        for i in range(pb.getNumJoints(self.id, physicsClientId=c)):
            info = pb.getJointInfo(self.id, i, physicsClientId=c)
            self.joint[info[1].decode()] = i
            self.link[info[12].decode()] = i
        names = self.arm_chain.names
        self.arm_joints = [self.joint[n] for n in names]
        self.forces = spec.force_limits()
        self._gains: dict[tuple, tuple[list, list]] = {}  # (position gain, velocity gain, n) -> the lists :meth:`command` sends
        self.held: dict[str, float] = {}
        for name, index in self.joint.items():
            if name not in names and pb.getJointInfo(self.id, index, physicsClientId=c)[2] == pb.JOINT_REVOLUTE:
                self.held[name] = 0.0
        for name, value in self.held.items():
            pb.resetJointState(self.id, self.joint[name], value, physicsClientId=c)

    def chain_to(self, link: str) -> ik.KinematicChain:
        """The kinematic chain from the world to ``link``."""
        return ik.KinematicChain.from_urdf(self.urdf, link, self.world_T_root, self.spec.base_link)

    def arm_angles(self) -> np.ndarray:
        """The arm's joint angles (n,), radians, chain order."""
        states = self.sim.pb.getJointStates(self.id, self.arm_joints, physicsClientId=self.sim.client)
        return np.array([s[0] for s in states])

    def angles(self, names) -> dict[str, float]:
        """Joint name -> angle (radians) now, for ``names``."""
        pb, c = self.sim.pb, self.sim.client
        return {n: float(pb.getJointState(self.id, self.joint[n], physicsClientId=c)[0]) for n in names}

    def link_pose(self, link: str) -> np.ndarray:
        """``world_T_link`` (4, 4) now (PyBullet's forward kinematics)."""
        state = self.sim.pb.getLinkState(self.id, self.link[link], computeForwardKinematics=True,
                                         physicsClientId=self.sim.client)
        return pose(from_quat(state[5]), state[4])

    def link_position(self, link: str) -> np.ndarray:
        """Origin (3,) of ``link`` now (agrees with the chains to 1e-8 m, 25x faster)."""
        state = self.sim.pb.getLinkState(self.id, self.link[link], computeForwardKinematics=True,
                                         physicsClientId=self.sim.client)
        return np.array(state[4])

    def set_arm(self, q: np.ndarray) -> None:
        """Teleport the arm to ``q`` and make the controllers hold it (and every held joint)."""
        pb, c = self.sim.pb, self.sim.client
        for index, value in zip(self.arm_joints, q):
            pb.resetJointState(self.id, index, float(value), 0.0, physicsClientId=c)
        self.command(q, np.zeros(len(q)))
        self.hold_head()

    def set_held(self, name: str, value: float) -> None:
        """Put a held joint (neck, eyes) at ``value`` radians at once."""
        self.held[name] = float(value)
        self.sim.pb.resetJointState(self.id, self.joint[name], float(value), 0.0, physicsClientId=self.sim.client)

    def hold_head(self) -> None:
        """Position-control the neck and eyes at their held angles."""
        held = [self.joint[n] for n in self.held]
        self.sim.pb.setJointMotorControlArray(
            self.id, held, self.sim.pb.POSITION_CONTROL, targetPositions=list(self.held.values()),
            forces=[self.spec.hold_force] * len(held), physicsClientId=self.sim.client)

    def command(self, q: np.ndarray, qd: np.ndarray, position_gain: float = 0.3, velocity_gain: float = 1.0) -> None:
        """Position targets ``q`` with velocity feed-forward ``qd`` for the arm."""
        pb = self.sim.pb
        gains = self._gains.get((position_gain, velocity_gain, len(q)))
        if gains is None:  # the same two lists at every control step: made once
            gains = self._gains[(position_gain, velocity_gain, len(q))] = ([position_gain] * len(q), [velocity_gain] * len(q))
        pb.setJointMotorControlArray(
            self.id, self.arm_joints, pb.POSITION_CONTROL, targetPositions=q.tolist(), targetVelocities=qd.tolist(),
            forces=self.forces, positionGains=gains[0], velocityGains=gains[1], physicsClientId=self.sim.client)
