"""``hila robot-sim``: the PyBullet arm as a ros2_control arm presents itself -- a joint trajectory
controller and a joint state broadcaster -- in its own process, the stand-in for hardware.

:class:`SimulatedArm` builds the same scene the PyBullet back end drives
(:class:`hila_lang.robot.backend.PyBulletBackend`: the robot, the table, the paper, the arm at its
ready posture) and runs its physics at 240 Hz, paced to the wall clock, with no IK of its own:

- it subscribes to the controller topic (``trajectory_msgs/JointTrajectory``) and follows each
  trajectory as a ``JointTrajectoryController`` does: the trajectory starts on receipt, from the
  state it is commanding then, through its points at their ``time_from_start`` (cubic between
  points that carry velocities, straight lines between points that do not), and holds its last
  point; a new trajectory replaces the one running (a one-point trajectory is how a client stops
  the arm);
- a trajectory whose joint names are not exactly the arm's is refused and said so, as the
  controller refuses one;
- it publishes ``sensor_msgs/JointState`` of the arm's joints (positions and velocities, stamped)
  at :data:`STATE_RATE` Hz;
- ``brakes``: joints held where they are whatever the trajectory says (a fault to provoke a
  trajectory that is not followed); ``prefix``: joint names as a namespaced driver publishes them.

Each trajectory it takes, refuses or is told to stop with is one line on its log (stderr), which
the tests read.
"""

from __future__ import annotations

import sys
import threading
import time

import numpy as np

from ..robot.arm import POSITION_GAIN, VELOCITY_GAIN
from ..robot.backend import PyBulletBackend
from ..robot.kinematic_arm import from_spec
from .link import joint_state_message, read_trajectory, ros_modules, RosNode
from .plan import hermite

#: physics rate, Hz (the PyBullet arm's)
PHYSICS_RATE = 240.0
#: joint states per second by default (every second physics step)
STATE_RATE = 120.0


class Following:
    """A trajectory being followed, started at physics time ``start`` from the commanded state
    ``(q, qd)`` (n,) each: knots at ``times`` (M,) after ``start`` with ``positions`` (M, n) and
    ``velocities`` (M, n) or None (straight lines)."""

    def __init__(self, start: float, q: np.ndarray, qd: np.ndarray, times, positions, velocities) -> None:
        self.start = float(start)
        if times[0] > 0:  # from where the controller is commanding now to the first point
            times = np.concatenate([[0.0], times])
            positions = np.vstack([q, positions])
            velocities = None if velocities is None else np.vstack([qd, velocities])
        self.times, self.positions, self.velocities = times, positions, velocities

    @property
    def end(self) -> float:
        return self.start + float(self.times[-1])

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Commanded positions and velocities (n,) at physics time ``t``."""
        local = t - self.start
        if self.velocities is not None:
            return hermite(self.times, self.positions, self.velocities, local)
        q = np.array([np.interp(local, self.times, column) for column in self.positions.T])
        i = int(np.clip(np.searchsorted(self.times, local, side="right") - 1, 0, len(self.times) - 2))
        inside = 0 <= local < self.times[-1] and len(self.times) > 1
        qd = (self.positions[i + 1] - self.positions[i]) / (self.times[i + 1] - self.times[i]) if inside else 0 * q
        return q, qd


class SimulatedArm:
    """The simulated arm node (see the module docstring).

    Parameters
    ----------
    robot : RobotSpec
        The robot (:func:`hila_lang.robot.spec.resolve`), loaded as the PyBullet back end loads it
        and described as the ROS back end plans with it
        (:func:`hila_lang.robot.kinematic_arm.from_spec`).
    controller, states : str
        The trajectory topic it listens on, the joint state topic it publishes.
    rate : float
        Joint states per second (rounded to a whole number of physics steps).
    prefix : str
        Put before every joint name it publishes and accepts.
    brakes : iterable of str
        Joints (the description's names) held where they are.
    gui : bool
        PyBullet's window.
    log : text stream
    """

    def __init__(self, robot, *, controller: str, states: str, rate: float = STATE_RATE,
                 prefix: str = "", brakes=(), gui: bool = False, log=None) -> None:
        _, JointTrajectory, _, JointState = ros_modules()  # before the simulation: a missing extra says so at once
        self.log = log or sys.stderr
        self.description = from_spec(robot)
        self.gains = (POSITION_GAIN, VELOCITY_GAIN)
        self.names = [prefix + n for n in self.description.joints]
        self.every = max(1, int(round(PHYSICS_RATE / float(rate))))
        self.dt = 1.0 / PHYSICS_RATE
        self.controller, self.states_topic = controller, states
        self.sim = PyBulletBackend(gui=gui, arm="ready", robot=robot)  # the scene the PyBullet back end drives
        try:
            self.body = self.sim.body
            if tuple(self.body.arm_chain.names) != self.description.joints:
                raise RuntimeError(f"the simulated body's arm {self.body.arm_chain.names} is not the description's "
                                   f"{self.description.joints}")
            self.q_cmd = self.body.arm_angles()
            self.qd_cmd = np.zeros_like(self.q_cmd)
            self.brakes = {self.description.joints.index(b): float(self.q_cmd[self.description.joints.index(b)])
                           for b in brakes}
            self.following: Following | None = None
            self.received = 0
            self._pending = None
            self._lock = threading.Lock()
            self.node = RosNode("hila_robot_sim")
            self.publisher = self.node.publisher(JointState, states, sensor=False)
            self.node.subscribe(JointTrajectory, controller, self._on_trajectory)
        except BaseException:
            self.close()
            raise

    @property
    def rate(self) -> float:
        """Joint states per second, as published."""
        return PHYSICS_RATE / self.every

    def say(self, text: str) -> None:
        print(f"robot-sim: {text}", file=self.log, flush=True)

    def _on_trajectory(self, msg) -> None:
        """The subscription's callback (the executor's thread): read, check, hand to the loop."""
        self.received += 1
        try:
            names, times, positions, velocities = read_trajectory(msg)
        except ValueError as exc:
            self.say(f"trajectory {self.received} refused: {exc}")
            return
        if sorted(names) != sorted(self.names):
            unknown = [n for n in names if n not in self.names]
            missing = [n for n in self.names if n not in names]
            self.say(f"trajectory {self.received} refused: its joints do not match this arm's "
                     f"(unknown: {', '.join(unknown) or '-'}; missing: {', '.join(missing) or '-'})")
            return
        order = [names.index(n) for n in self.names]
        positions = positions[:, order]
        velocities = None if velocities is None else velocities[:, order]
        if len(times) == 1:
            tip = self.description.tip(positions[0])
            self.say(f"trajectory {self.received}: a stop, 1 point in {times[0]:.2f} s: holding the tool at "
                     f"({tip[0]:.3f}, {tip[1]:.3f}, {tip[2]:.3f})")
        else:
            self.say(f"trajectory {self.received}: {len(times)} points over {times[-1]:.2f} s")
        with self._lock:
            self._pending = (times, positions, velocities)

    def step(self, k: int) -> None:
        """Physics step ``k`` (time ``k * dt``): take a new trajectory, command, step, publish."""
        t = k * self.dt
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is not None:
            self.following = Following(t, self.q_cmd, self.qd_cmd, *pending)
        if self.following is not None:
            # PyBullet's motor ends a step at (target + dt * velocity): aim at now, move at the next
            q_now, _ = self.following.sample(t)
            self.q_cmd, self.qd_cmd = self.following.sample(t + self.dt)
            target, speed = q_now.copy(), self.qd_cmd.copy()
        else:
            target, speed = self.q_cmd.copy(), np.zeros_like(self.q_cmd)
        for j, held in self.brakes.items():
            target[j], speed[j] = held, 0.0
        self.body.command(target, speed, *self.gains)
        self.sim.sim.pb.stepSimulation(physicsClientId=self.sim.sim.client)
        if k % self.every == 0:
            states = self.sim.sim.pb.getJointStates(self.body.id, self.body.arm_joints, physicsClientId=self.sim.sim.client)
            self.publisher.publish(joint_state_message(self.names, [s[0] for s in states], [s[1] for s in states],
                                                       self.node.now()))

    def run(self, seconds: float | None = None) -> None:
        """Step in real time until ``seconds`` pass (None: until Ctrl-C or SIGTERM)."""
        self.say(f"{self.description.robot} ready: {len(self.names)} joints ({', '.join(self.names)}); trajectories "
                 f"on {self.controller}, joint states on {self.states_topic} at {self.rate:g} Hz"
                 + (f"; brakes on {', '.join(self.description.joints[j] for j in self.brakes)}" if self.brakes else ""))
        started = time.monotonic()
        k = 0
        while seconds is None or k * self.dt < seconds:
            self.step(k)
            k += 1
            ahead = started + k * self.dt - time.monotonic()
            if ahead > 0:
                time.sleep(ahead)

    def close(self) -> None:
        """Leave the ROS graph and close the simulation (idempotent)."""
        node = self.__dict__.pop("node", None)
        if node is not None:
            node.close()
        sim = self.__dict__.pop("sim", None)
        if sim is not None:
            sim.close()
