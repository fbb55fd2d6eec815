"""hila's side of ROS 2: a node in its own context, the two messages it speaks, and the arm's
joint states as they arrive.

Everything ROS is imported here, inside functions (``rclpy`` and the message packages come with
``pip install 'hila-lang[ros]'``); conversions between messages and numpy arrays happen here and
nowhere else:

- ``trajectory_msgs/JointTrajectory`` (what ros2_control's ``JointTrajectoryController`` takes on
  ``/<controller>/joint_trajectory``): joint names, points with positions, velocities and
  ``time_from_start``; a zero ``header.stamp`` means "start on receipt".
- ``sensor_msgs/JointState`` (what its ``joint_state_broadcaster`` publishes on
  ``/joint_states``): names, positions, velocities, a stamp.

:class:`RosNode` runs one node in a private ``rclpy`` context, spun by an executor in a daemon
thread, with ROS's own signal handlers off (hila handles Ctrl-C and SIGTERM:
:mod:`hila_lang.core.interrupts`) and no log files.  :class:`JointStates` keeps the newest state of
the arm's joints, in the description's order, and every state while a move records them; callers
wait on it with time-outs (interruptible by Ctrl-C).  Discovery follows the environment:
``ROS_DOMAIN_ID``, ``ROS_AUTOMATIC_DISCOVERY_RANGE``.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

from ..core.errors import HilaRuntimeError, InputError

#: history depth of the trajectory publisher (reliable, volatile: what the controller subscribes with)
QUEUE = 10


def ros_modules():
    """``(rclpy, JointTrajectory, JointTrajectoryPoint, JointState)``; an InputError saying how to
    install them when the ``ros`` extra is missing."""
    try:
        # lazy: rclpy and the message packages are the optional 'ros' extra
        import rclpy
        from sensor_msgs.msg import JointState
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    except ImportError as exc:
        raise InputError(f"the ROS 2 back end needs rclpy and the ROS message packages ({exc.name or exc} is "
                         "missing)", hint="pip install 'hila-lang[ros]' (see docs/real-robot.md)") from None
    return rclpy, JointTrajectory, JointTrajectoryPoint, JointState


def _seconds(stamp) -> float:
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def _duration(seconds: float):
    # lazy: builtin_interfaces is an optional extra
    from builtin_interfaces.msg import Duration

    whole = int(np.floor(seconds))
    return Duration(sec=whole, nanosec=int(round((seconds - whole) * 1e9)) % 1_000_000_000)


def trajectory_message(names, times, positions, velocities=None):
    """A ``JointTrajectory`` (stamp zero: start on receipt) of knots at ``times`` (M,) seconds with
    ``positions`` and ``velocities`` (M, n), radians and rad/s."""
    _, JointTrajectory, JointTrajectoryPoint, _ = ros_modules()
    msg = JointTrajectory()
    msg.joint_names = list(names)
    for k, t in enumerate(times):
        point = JointTrajectoryPoint()
        point.positions = [float(v) for v in positions[k]]
        if velocities is not None:
            point.velocities = [float(v) for v in velocities[k]]
        point.time_from_start = _duration(float(t))
        msg.points.append(point)
    return msg


def read_trajectory(msg) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray | None]:
    """``(names, times (M,), positions (M, n), velocities (M, n) or None)`` of a ``JointTrajectory``;
    a ValueError saying what is wrong with it (as a controller refuses one)."""
    names = list(msg.joint_names)
    if not msg.points:
        raise ValueError("it has no points")
    times = np.array([_seconds(p.time_from_start) for p in msg.points])
    positions = [list(p.positions) for p in msg.points]
    if any(len(p) != len(names) for p in positions):
        raise ValueError(f"a point has not one position per joint ({len(names)} joints)")
    with_velocities = all(len(p.velocities) == len(names) for p in msg.points)
    if np.any(np.diff(times) <= 0) or times[0] < 0:
        raise ValueError("its times are not increasing from 0")
    q = np.array(positions, dtype=float)
    qd = np.array([list(p.velocities) for p in msg.points], dtype=float) if with_velocities else None
    if not np.all(np.isfinite(q)) or (qd is not None and not np.all(np.isfinite(qd))):
        raise ValueError("it holds a number that is not finite")
    return names, times, q, qd


def joint_state_message(names, positions, velocities, stamp):
    """A ``JointState`` of ``names`` at ``positions``/``velocities`` (n,), stamped ``stamp`` (a ROS time message)."""
    _, _, _, JointState = ros_modules()
    msg = JointState()
    msg.header.stamp = stamp
    msg.name = list(names)
    msg.position = [float(v) for v in positions]
    msg.velocity = [float(v) for v in velocities]
    return msg


class RosNode:
    """One ROS 2 node in its own context, spun in a daemon thread (see the module docstring)."""

    def __init__(self, name: str) -> None:
        rclpy, *_ = ros_modules()
        # lazy: rclpy is an optional extra
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self.context = Context()
        rclpy.init(args=["--ros-args", "--disable-external-lib-logs"], context=self.context,
                   signal_handler_options=SignalHandlerOptions.NO)
        try:
            self.node = rclpy.create_node(name, context=self.context)
            self.executor = SingleThreadedExecutor(context=self.context)
            self.executor.add_node(self.node)
        except BaseException:
            self.context.try_shutdown()
            raise
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._spin, args=(self.context, self.executor), name=f"ros-{name}",
                                        daemon=True)
        self._thread.start()

    def _spin(self, context, executor) -> None:
        # lazy: rclpy is an optional extra
        from rclpy.executors import ExternalShutdownException

        try:
            while not self._stopping.is_set() and context.ok():
                executor.spin_once(timeout_sec=0.05)
        except (ExternalShutdownException, RuntimeError):  # the context was shut down meanwhile
            pass

    def publisher(self, kind, topic: str, sensor: bool = False):
        # lazy: rclpy is an optional extra
        from rclpy.qos import qos_profile_sensor_data

        return self.node.create_publisher(kind, topic, qos_profile_sensor_data if sensor else QUEUE)

    def subscribe(self, kind, topic: str, callback, sensor: bool = False):
        """``sensor``: best effort (matches a reliable publisher as well as a best-effort one)."""
        # lazy: rclpy is an optional extra
        from rclpy.qos import qos_profile_sensor_data

        return self.node.create_subscription(kind, topic, callback, qos_profile_sensor_data if sensor else QUEUE)

    def now(self):
        """The node's clock now, as a ``builtin_interfaces/Time`` message."""
        return self.node.get_clock().now().to_msg()

    def close(self) -> None:
        """Stop spinning, destroy the node, shut the context down (idempotent)."""
        context = self.__dict__.pop("context", None)
        if context is None:
            return
        self._stopping.set()
        self._thread.join(timeout=2.0)  # spin_once returns within its 0.05 s
        try:
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        finally:
            context.try_shutdown()


@dataclass
class State:
    """One ``/joint_states`` message, read: when it came (``time.monotonic()``), its stamp
    (seconds, the sender's clock) and the arm's joint positions (n,) in the description's order."""

    received: float
    stamp: float
    positions: np.ndarray


class JointStates:
    """The arm's joint states from a ``JointState`` topic, in the order of ``joints``.

    :attr:`latest` is the newest :class:`State` (None before the first); while :meth:`recording`
    every state is kept too.  A message without every one of ``joints`` is not a state of this
    arm: its names are kept in :attr:`mismatch` (what came) for the error that names them.
    """

    def __init__(self, joints) -> None:
        self.joints = tuple(joints)
        self.latest: State | None = None
        #: the state before :attr:`latest`
        self.before: State | None = None
        self.mismatch: list[str] | None = None
        self.count = 0
        self._recorded: list[State] | None = None
        self._changed = threading.Condition()

    def on_message(self, msg) -> None:
        """The subscription's callback (the executor's thread)."""
        received = time.monotonic()
        names = list(msg.name)
        index = {n: i for i, n in enumerate(names)}
        if any(j not in index for j in self.joints) or len(msg.position) != len(names):
            with self._changed:
                self.mismatch = names
                self._changed.notify_all()
            return
        state = State(received, _seconds(msg.header.stamp), np.array([msg.position[index[j]] for j in self.joints]))
        with self._changed:
            self.before, self.latest = self.latest, state
            self.count += 1
            if self._recorded is not None:
                self._recorded.append(state)
            self._changed.notify_all()

    def wait(self, until, timeout: float) -> bool:
        """Wait (Ctrl-C interrupts it) until ``until()`` is true or ``timeout`` seconds pass; returns
        ``until()``."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while not until():
                left = deadline - time.monotonic()
                if left <= 0:
                    return bool(until())
                self._changed.wait(min(left, 0.05))
            return True

    def record(self) -> None:
        """Keep every state from now on (a move)."""
        with self._changed:
            self._recorded = []

    def recorded(self, stop: bool = False) -> list[State]:
        """The states kept since :meth:`record` (a copy); ``stop``: keep no more."""
        with self._changed:
            out = list(self._recorded or [])
            if stop:
                self._recorded = None
            return out

    def mismatch_error(self, topic: str, robot: str) -> HilaRuntimeError:
        """The joint names in ``topic`` do not include the arm's (``robot``'s): which are missing,
        what came; when none of them came, the hint asks first whether the robot is the arm's."""
        came = self.mismatch or []
        missing = [j for j in self.joints if j not in came]
        shown = ", ".join(came[:12]) + (f", ... ({len(came)} in all)" if len(came) > 12 else "")
        hint = "give the controller's names with --set ros.joints=NAME,NAME,... (in the robot's chain order)"
        if len(missing) == len(self.joints):
            hint = (f"none of the {robot}'s joints came: is the arm the {robot}? --robot NAME|PATH names the robot "
                    f"hila plans with (hila robot-sim takes the same --robot); if it is, {hint}")
        return HilaRuntimeError(
            f"the joint names in {topic} do not match the robot's ({robot}: {', '.join(self.joints)}): missing "
            f"{', '.join(missing)}; {topic} names {shown or 'no joints'}", hint=hint)
