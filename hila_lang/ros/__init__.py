"""A real robot's interface: the ROS 2 back end (``--backend ros``) and ``hila robot-sim``, the
simulated arm that speaks ROS 2 as ros2_control does.

- :mod:`hila_lang.ros.plan`     IK along a path, timed under the speed caps, checked whole before it is sent
- :mod:`hila_lang.ros.link`     the ROS 2 node, the trajectory and joint-state messages, the joint states as they come
- :mod:`hila_lang.ros.backend`  :class:`RosBackend`: trajectories out, ``/joint_states`` back, stops on failure
- :mod:`hila_lang.ros.simarm`   the PyBullet arm as a trajectory controller and joint-state broadcaster

``ROS`` declares the back end (entry point ``hila.backends``).  Importing this package imports
nothing heavy; ``rclpy`` and the message packages (``pip install 'hila-lang[ros]'``) are imported
by :mod:`.link` when a node starts.  The page for people: ``docs/real-robot.md``.

The defaults, and why: ``ros.tolerance`` 2 mm is the bound the executed path keeps to the plan on
``hila robot-sim`` with a wide margin (``bench/ros.py``: moves end 0.03 mm off at most);
``ros.silence`` 0.5 s is 10 times the longest gap between two joint states measured during moves
at 120 Hz with the machine loaded (load average 24: 47 ms; 99th percentile 15-27 ms); ``ros.timeout``
10 s is 20 times the half second two processes here took to find each other over DDS;
``ros.gap`` 0.15 m lets the shipped programs start where they do (``write.hila`` 0.103 m from the
pen at most) and refuses a path that begins somewhere else entirely.
"""

from ..plugins.registry import BackendInfo
from ..plugins.settings import Setting, choice, number, text
from ..robot import PYBULLET

#: a ROS topic name (relative or absolute)
TOPIC = r"/?[A-Za-z~][A-Za-z0-9_~{}]*(/[A-Za-z0-9_~{}]+)*"


def _joints(value: str) -> tuple[str, ...]:
    names = tuple(n.strip() for n in value.split(",") if n.strip())
    if not names or any(not n.replace("_", "").replace("/", "").isalnum() for n in names):
        raise ValueError(f"expected joint names separated by commas, got {value!r}")
    return names


def _workspace(value: str):
    # lazy: loads numpy, which importing this module does not
    from .plan import Workspace

    return Workspace.parse(value)


ROS = BackendInfo(
    name="ros",
    factory="hila_lang.ros.backend:make_backend",
    doc="a real arm (or hila robot-sim) through ROS 2: a ros2_control joint trajectory controller and /joint_states "
        "(pip install 'hila-lang[ros]'; docs/real-robot.md)",
    settings=(
        Setting("ros.controller", "the controller's trajectory topic (trajectory_msgs/JointTrajectory)",
                text(TOPIC, "a ROS topic name"), default="/joint_trajectory_controller/joint_trajectory",
                metavar="TOPIC"),
        Setting("ros.states", "the joint state topic (sensor_msgs/JointState)", text(TOPIC, "a ROS topic name"),
                default="/joint_states", metavar="TOPIC"),
        Setting("ros.joints", "the controller's names of the arm's joints, in the chain's order (default: the "
                              "robot description's, from its URDF)", _joints, metavar="NAME,NAME,..."),
        Setting("ros.speed", "the tool's speed cap, m/s (the pen moves at 0.05 m/s down, 0.15 up, never faster than "
                             "this)", number(0.001, 1.0), default=0.15, metavar="M_PER_S"),
        Setting("ros.workspace", "the box the tool must stay in, metres (default: over the table, from 2 mm under the "
                                 "paper to 0.40 m above it)", _workspace, metavar="XMIN,XMAX,YMIN,YMAX,ZMIN,ZMAX"),
        Setting("ros.timeout", "seconds to wait for the controller and the first joint state", number(0.1, 600.0),
                default=10.0, metavar="SECONDS"),
        Setting("ros.silence", "longest wait for the next joint state during a move before it is given up, seconds",
                number(0.05, 60.0), default=0.5, metavar="SECONDS"),
        Setting("ros.tolerance", "how far from the planned end the arm may stop, metres", number(0.0001, 0.1),
                default=0.002, metavar="METRES"),
        Setting("ros.gap", "how far from the tool a path may start, metres (the bridge is planned and checked too)",
                number(0.0, 1.0), default=0.15, metavar="METRES"),
        Setting("ros.confirm", "show each move's plan and ask before sending it: before the first move, before "
                               "each, or never", choice("first", "each", "no"), default="no", metavar="first|each|no",
                flag="--confirm"),
    ),
    # the default robot's, as the PyBullet back end declares it; a run's --robot is checked against
    # that robot's reach (hila check: language/worldcheck.py; a move: the spec's, plan.py)
    reach=PYBULLET.reach,
)
