"""The ROS 2 back end: a program's paths sent to an arm's ``JointTrajectoryController``, the path it
took read back from ``/joint_states``.

:class:`RosBackend` implements :class:`hila_lang.plugins.protocols.Backend`.  It knows the arm only
through its description (:class:`~hila_lang.robot.kinematic_arm.KinematicArm`: joint names,
kinematics, limits, speed caps) and what the arm reports; it decides from the *measured* joint
angles, never from what it sent.

- On start it waits (``ros.timeout``) for a controller subscribed to ``ros.controller`` and for a
  first joint state on ``ros.states`` naming every joint of the arm; either missing is one line
  naming the topic, a state with other joint names names what is missing and what came.
- :meth:`RosBackend.move`: the path is planned from the measured angles and checked whole
  (:func:`hila_lang.ros.plan.plan_move`: reach, joint limits, speed caps, the workspace box, the
  path's start near the measured tool), shown and confirmed first with ``ros.confirm``, and sent as
  one ``JointTrajectory``.  While the arm moves every joint state is kept; the executed path -- the
  tool through forward kinematics of those states -- is what ``move`` returns, so ``--record``,
  ``replay`` and the ``via``/``avoid`` checks measure what the arm did.  After the trajectory's
  time the arm has :data:`SETTLE` s to come to rest; ending more than ``ros.tolerance`` from the
  planned end is a failure that says how far.
- No joint state for ``ros.silence`` s during a move (the arm's driver died) ends the move: exit 1,
  the path so far kept, and the message says when the last state came and where the arm was.
- Ctrl-C, SIGTERM and any failure during a move send a stop first: a one-point trajectory holding
  the newest measured position (reached in :data:`STOP_TIME` s); the joint states are kept until
  they say the arm rests (at most :data:`STOP_WAIT` s), then the error goes on its way with the
  executed part of the move, the stop included, attached (``exc.executed``), so the run saves it
  (:mod:`hila_lang.engine.interpreter`).
- ``reset_hand`` (``hand at``, a world parking the arm) is a real motion on a real arm: planned,
  checked and confirmed like a move, from wherever the tool is.

It has no eyes, ink, overview, lighting or window, and no snapshots: a real arm cannot go back.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.bounded import BoundedLog
from ..core.errors import HilaRuntimeError, InputError
from ..robot.kinematic_arm import from_spec
from ..robot.reach import BELOW_PAPER
from ..robot.workspace import TABLE_FRONT_X, TABLE_SIZE
from .link import JointStates, ros_modules, RosNode, State, trajectory_message
from .plan import JointPlan, plan_move, Workspace

#: after a trajectory's last point, the arm has this long to come to rest within the tolerance, s
SETTLE = 1.0
#: two joint states whose tool points are nearer than this are "at rest", metres
AT_REST = 5e-5
#: a stop's one point is reached this long after it is received, seconds (a time of zero makes
#: some controllers jump to it in one control cycle)
STOP_TIME = 0.05
#: how long a stop waits for the joint states to say the arm rests, seconds
STOP_WAIT = 1.0
#: moves kept in :attr:`RosBackend.moves`
KEEP_MOVES = 1000


def _fmt(p) -> str:
    return "(" + ", ".join(f"{float(v):.3f}" for v in p) + ")"


def _clock(monotonic: float) -> str:
    """A ``time.monotonic()`` instant as wall-clock time, ``14:02:03.512``."""
    wall = time.time() - (time.monotonic() - monotonic)
    return time.strftime("%H:%M:%S", time.localtime(wall)) + f".{int(wall * 1000) % 1000:03d}"


@dataclass
class Move:
    """One move sent to the arm: its plan, when it was sent (``time.monotonic()``) and the joint
    states that came while it ran (and settled)."""

    plan: JointPlan
    sent: float
    states: list = field(repr=False)
    executed: np.ndarray = field(repr=False)

    def latency(self, moved: float = 1e-3) -> float | None:
        """Seconds from sending to the first state whose joints moved more than ``moved`` rad from
        the first; None when none did."""
        if not self.states:
            return None
        start = self.states[0].positions
        for s in self.states:
            if np.max(np.abs(s.positions - start)) > moved:
                return s.received - self.sent
        return None


class RosBackend:
    """The arm behind a ROS 2 trajectory controller (see the module docstring)."""

    name = "ros"
    eyes = None
    ink = None
    overview = None
    view = None
    lighting = None
    snapshots = None
    streaming = None  # a track clause re-plans while the arm moves: not over a trajectory controller yet

    def __init__(self, arm, *, joints=None, controller: str, states: str, speed: float, workspace: Workspace | None,
                 timeout: float = 10.0, silence: float = 0.5, tolerance: float = 0.002, gap: float = 0.15,
                 confirm: str = "no", stdin=None, stdout=None) -> None:
        self.arm = arm
        #: the robot's spec (:class:`~hila_lang.robot.spec.RobotSpec`), as the PyBullet back end has
        #: it (a world's report names the robot)
        self.robot = arm.spec
        self.joints = tuple(joints or arm.joints)
        if len(self.joints) != arm.dof:
            raise InputError(f"ros.joints names {len(self.joints)} joints; the {arm.robot}'s arm has {arm.dof} "
                             f"({', '.join(arm.joints)})", hint="one controller joint name per joint, in that order")
        self.controller, self.states_topic = controller, states
        self.speed, self.workspace, self.silence = float(speed), workspace, float(silence)
        self.tolerance, self.gap, self.confirm = float(tolerance), float(gap), confirm
        self.stdin, self.stdout = stdin or sys.stdin, stdout or sys.stdout
        self._confirmed = False
        #: every move sent (:class:`Move`), the newest :data:`KEEP_MOVES` kept
        self.moves: BoundedLog = BoundedLog(KEEP_MOVES)
        _, JointTrajectory, _, JointState = ros_modules()
        self.node = RosNode("hila")
        try:
            self.states = JointStates(self.joints)
            self.node.subscribe(JointState, states, self.states.on_message, sensor=True)
            self.publisher = self.node.publisher(JointTrajectory, controller)
            self._connect(float(timeout))
        except BaseException:
            self.close()
            raise

    # -- connecting -----------------------------------------------------------------------------
    def _connect(self, timeout: float) -> None:
        """Wait for the controller and a first state of this arm (one line naming what is missing)."""
        s = self.states
        found = s.wait(lambda: self.publisher.get_subscription_count() > 0 and (s.latest is not None or s.mismatch),
                       timeout)
        if self.publisher.get_subscription_count() == 0:
            raise HilaRuntimeError(f"no controller on {self.controller}: nothing subscribed to it within {timeout:g} s",
                                   hint=self._where_hint(self.controller))
        if not found and s.latest is None and not s.mismatch:
            raise HilaRuntimeError(f"no joint states on {self.states_topic} within {timeout:g} s",
                                   hint=self._where_hint(self.states_topic))
        if s.latest is None:
            raise s.mismatch_error(self.states_topic, self.arm.robot)

    @staticmethod
    def _where_hint(topic: str) -> str:
        domain = os.environ.get("ROS_DOMAIN_ID", "0 (unset)")
        return (f"is the arm's driver running (hila robot-sim, or ros2_control) with the same ROS_DOMAIN_ID (here "
                f"{domain})? 'ros2 topic info {topic}' shows who is on it; --set ros.controller=/NAME/joint_trajectory "
                "names another controller")

    def _measured(self) -> State:
        """The newest joint state, no older than ``ros.silence`` (waits that long for one)."""
        s = self.states
        fresh = lambda: s.latest is not None and time.monotonic() - s.latest.received <= self.silence  # noqa: E731
        if not s.wait(fresh, self.silence):
            last = s.latest
            raise HilaRuntimeError(f"no joint states on {self.states_topic} for {time.monotonic() - last.received:.2f} s "
                                   f"(the last came at {_clock(last.received)}); the arm was not moved",
                                   hint=self._where_hint(self.states_topic))
        return s.latest

    # -- Backend --------------------------------------------------------------------------------
    def hand_position(self) -> np.ndarray:
        """The tool tip (3,) from the newest measured joint angles, world frame, metres."""
        return self.arm.tip(self._measured().positions)

    def reset_hand(self, point: np.ndarray) -> None:
        """Move the tool to ``point`` (3,) (a real motion: planned, checked, confirmed; no trace)."""
        p = np.asarray(point, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InputError(f"expected a hand position of 3 finite numbers, got {p.tolist()}")
        self._run(p[None], pen_down=False, label="hand at", gap=np.inf)

    def move(self, path, *, pen_down: bool = False, label: str = "") -> np.ndarray:
        """Follow ``path`` (T, 3); returns the executed tool path (T', 3), from ``/joint_states``."""
        return self._run(path, pen_down=pen_down, label=label, gap=self.gap)

    def close(self) -> None:
        """Leave the ROS graph (idempotent)."""
        node = self.__dict__.pop("node", None)
        if node is not None:
            node.close()

    # -- a move ---------------------------------------------------------------------------------
    def _run(self, path, *, pen_down: bool, label: str, gap: float) -> np.ndarray:
        start = self._measured()
        plan = plan_move(self.arm, start.positions, path, pen_down=pen_down, speed=self.speed,
                         workspace=self.workspace, gap=gap, label=label)
        self._ask(plan)
        if len(plan.times) < 2:  # nowhere to go
            return self.arm.tip(start.positions)[None]
        self.states.record()
        sent = time.monotonic()
        try:
            self.publisher.publish(trajectory_message(self.joints, plan.times, plan.positions, plan.velocities))
            self._follow(plan, sent)
        except BaseException as exc:  # Ctrl-C, SIGTERM, the arm's silence, a trajectory not followed
            self._stop()  # first; the states keep being recorded until the arm rests
            states = self.states.recorded(stop=True)
            exc.executed = self._executed(states)
            self.moves.append(Move(plan, sent, states, exc.executed))
            raise
        states = self.states.recorded(stop=True)
        move = Move(plan, sent, states, self._executed(states))
        self.moves.append(move)
        return move.executed

    def _executed(self, states) -> np.ndarray:
        return self.arm.tips([s.positions for s in states]) if states else np.empty((0, 3))

    def _follow(self, plan: JointPlan, sent: float) -> None:
        """Wait while the arm runs ``plan``, then until it rests (at most :data:`SETTLE` s); raise when
        the states stop coming or the arm ends off the plan."""
        s = self.states
        end, give_up = sent + plan.duration, sent + plan.duration + SETTLE
        seen, previous = s.count, None
        while True:
            if not s.wait(lambda: s.count > seen, self.silence):
                raise self._silent(plan, sent)
            seen, now = s.count, time.monotonic()
            tip = self.arm.tip(s.latest.positions)
            if now >= end:
                resting = previous is not None and np.linalg.norm(tip - previous) < AT_REST
                if (resting and np.linalg.norm(tip - plan.end) <= self.tolerance / 2) or now >= give_up:
                    break
            previous = tip
        off = float(np.linalg.norm(tip - plan.end))
        if off > self.tolerance:
            q_end = plan.positions[-1]
            j = int(np.argmax(np.abs(s.latest.positions - q_end)))
            raise HilaRuntimeError(
                f"the arm did not follow the trajectory: {plan.duration + SETTLE:.2f} s after it was sent the tool is "
                f"{off * 1000:.1f} mm from the planned end {_fmt(plan.end)}, at {_fmt(tip)} (ros.tolerance = "
                f"{self.tolerance * 1000:.1f} mm); {self.joints[j]} is {abs(s.latest.positions[j] - q_end[j]):.3f} rad "
                "from its target",
                hint="is a joint blocked, or the controller's gains too weak? the arm was stopped where it is")

    def _silent(self, plan: JointPlan, sent: float) -> HilaRuntimeError:
        last = self.states.latest
        gap = time.monotonic() - last.received
        into = last.received - sent
        return HilaRuntimeError(
            f"no joint states on {self.states_topic} for {gap:.2f} s during a move: the last came at "
            f"{_clock(last.received)}, {plan.where(max(into, 0.0))}, with the tool at "
            f"{_fmt(self.arm.tip(last.positions))}; the move was given up and a stop sent",
            hint="the arm's driver (hila robot-sim, ros2_control) stopped publishing: check it before running again")

    def _stop(self) -> None:
        """Send a one-point trajectory holding the newest measured position, wait (at most
        :data:`STOP_WAIT` s) for the joint states to say the arm rests, and say so on stderr."""
        s = self.states
        last = s.latest
        if last is None or "node" not in self.__dict__:
            return
        try:
            msg = trajectory_message(self.joints, [STOP_TIME], last.positions[None], np.zeros((1, len(self.joints))))
            self.publisher.publish(msg)
        except Exception as exc:  # noqa: BLE001 - the move's own error is what the user must see
            print(f"note: sending the stop to {self.controller} failed: {exc}", file=sys.stderr)
            return
        sent = time.monotonic()

        def resting() -> bool:
            a, b = s.before, s.latest
            return (b.received > sent + STOP_TIME and a is not None
                    and np.linalg.norm(self.arm.tip(a.positions) - self.arm.tip(b.positions)) < AT_REST)

        head = f"stop sent to {self.controller} (hold the joints measured at {_clock(last.received)})"
        if s.wait(resting, STOP_WAIT):
            print(f"{head}: the arm rests, the tool at {_fmt(self.arm.tip(s.latest.positions))}", file=sys.stderr)
        else:
            print(f"{head}: no joint states said the arm rests within {STOP_WAIT:g} s (the last came at "
                  f"{_clock(s.latest.received)})", file=sys.stderr)

    def _ask(self, plan: JointPlan) -> None:
        """``ros.confirm``: show the move and ask before sending it (``first``: before the first)."""
        if self.confirm == "no" or (self.confirm == "first" and self._confirmed):
            return
        print(plan.summary(), file=self.stdout)
        print("send it to the arm? [y/N] ", end="", file=self.stdout, flush=True)
        answer = self.stdin.readline()
        if answer.strip().lower() not in ("y", "yes"):
            raise HilaRuntimeError(f"the move {plan.label or ''} was not confirmed ({answer.strip() or 'no answer'!r}); "
                                   "the arm did not move")
        self._confirmed = True


def default_workspace(surface_z: float) -> Workspace:
    """Above the table in front of the robot: the table's top (:mod:`hila_lang.robot.workspace`) from
    :data:`~hila_lang.robot.reach.BELOW_PAPER` under the paper at ``surface_z`` up to
    :data:`WORKSPACE_HEIGHT` above it."""
    depth, width, _ = TABLE_SIZE
    return Workspace((TABLE_FRONT_X, -0.05 - width / 2, surface_z - BELOW_PAPER),
                     (TABLE_FRONT_X + depth, -0.05 + width / 2, surface_z + WORKSPACE_HEIGHT))


#: how high above the paper the default workspace box reaches, metres (the shipped programs go
#: at most 0.18 m above it: reach_return's home)
WORKSPACE_HEIGHT = 0.40


def make_backend(scene, options, settings) -> RosBackend:
    """Plug-in factory: the run's robot (``options.robot``, a :class:`~hila_lang.robot.spec.RobotSpec`
    from ``--robot``; None: the default robot) as :func:`~hila_lang.robot.kinematic_arm.from_spec`
    describes it, and the ``ros.*`` settings (:data:`hila_lang.ros.ROS`); the workspace box
    defaults to the table under the world's drawing surface (the robot's default sheet otherwise)."""
    robot = getattr(options, "robot", None)
    if robot is None:
        # lazy: only this branch needs it
        from ..robot.spec import resolve

        robot = resolve()
    arm = from_spec(robot)
    surface = scene.surface if scene is not None and scene.surface is not None else robot.default_surface()
    workspace = settings.get("ros.workspace") or default_workspace(surface.z)
    return RosBackend(arm, joints=settings.get("ros.joints"), controller=settings["ros.controller"],
                      states=settings["ros.states"], speed=settings["ros.speed"], workspace=workspace,
                      timeout=settings["ros.timeout"], silence=settings["ros.silence"],
                      tolerance=settings["ros.tolerance"], gap=settings["ros.gap"], confirm=settings["ros.confirm"],
                      stdin=options.stdin, stdout=options.stdout)
