"""``hila robot-sim``: a simulated arm that speaks ROS 2 as ros2_control does, in its own process.

The stand-in for hardware that ``--backend ros`` drives (:mod:`hila_lang.ros.simarm`): the PyBullet
arm at 240 Hz, a joint trajectory controller on ``--controller`` and a joint state broadcaster on
``--states``.  It runs until Ctrl-C or SIGTERM (exit 130, 143) or ``--seconds``.
"""

from __future__ import annotations

import argparse
import difflib
import re

from ..core.argtypes import number
from ..core.errors import InputError
from ..core.interrupts import exit_code
from ..plugins import registry
from ..ros import TOPIC

HELP = "a simulated arm behind ROS 2 topics (trajectory controller + /joint_states) for --backend ros"
DESCRIPTION = """\
Start the PyBullet arm as a ROS 2 node, the stand-in for a real arm with ros2_control: it follows
trajectory_msgs/JointTrajectory messages on the controller topic (as a JointTrajectoryController
does: from receipt, cubic between points with velocities, a new one replaces the running one) with
240 Hz physics paced to the wall clock, and publishes sensor_msgs/JointState on the joint state
topic. Then, in another terminal:

    hila exec programs/reach_return.hila --backend ros

Both sides must describe the same robot: give hila exec the --robot (and --set robot.KEY) given
here, e.g. hila robot-sim --robot panda, then hila exec ... --backend ros --robot panda.

Discovery follows ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE (LOCALHOST keeps it on this
machine). Each trajectory taken, refused or stopped is one line on stderr. Needs the ros extra:
pip install 'hila-lang[ros]' (docs/real-robot.md)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robot", default=None, metavar="NAME|PATH",
                        help="the robot: a name (" + ", ".join(registry.names("robot")) + "; default icub), a spec "
                             "file (.yaml) or a URDF (.urdf), as hila exec --robot takes it (docs/robots.md)")
    parser.add_argument("--set", dest="robot_settings", action="append", default=[], metavar="robot.KEY=VALUE",
                        help="the robot's settings, as hila exec takes them: robot.tip=LINK, "
                             "robot.packages=DIR[:DIR], robot.base=X,Y,Z, robot.pen=METRES; repeatable")
    parser.add_argument("--controller", default="/joint_trajectory_controller/joint_trajectory", metavar="TOPIC",
                        help="the trajectory topic it listens on (default /joint_trajectory_controller/joint_trajectory)")
    parser.add_argument("--states", default="/joint_states", metavar="TOPIC",
                        help="the joint state topic it publishes (default /joint_states)")
    parser.add_argument("--rate", type=number(10.0, 240.0), default=120.0, metavar="HZ",
                        help="joint states per second, 10-240 (default 120; physics runs at 240 Hz)")
    parser.add_argument("--prefix", default="", metavar="TEXT",
                        help="put TEXT before every joint name, as a namespaced driver does (default none)")
    parser.add_argument("--brake", action="append", default=[], metavar="JOINT",
                        help="hold JOINT where it starts whatever it is told (a fault: a trajectory the arm does "
                             "not follow); repeatable")
    parser.add_argument("--seconds", type=number(0.0, 1e6), default=None, metavar="S",
                        help="stop after S seconds (default: run until Ctrl-C or SIGTERM)")
    parser.add_argument("--gui", action="store_true", help="show PyBullet's window (needs a display)")


def run(args: argparse.Namespace) -> int:
    # lazy: loads numpy, which importing this module does not
    from ..robot.spec import resolve, robot_pairs
    from ..ros.simarm import SimulatedArm

    for flag, topic in (("--controller", args.controller), ("--states", args.states)):
        if not re.fullmatch(TOPIC, topic):
            raise InputError(f"{flag} {topic!r} is not a ROS topic name")
    if args.prefix and not re.fullmatch(r"[A-Za-z0-9_/]+", args.prefix):
        raise InputError(f"--prefix {args.prefix!r}: expected letters, digits, _ or /")
    robot = resolve(args.robot, robot_pairs(args.robot_settings, "hila robot-sim"))
    joints = robot.chain().names
    for name in args.brake:
        if name not in joints:
            close = difflib.get_close_matches(name, joints, n=1)
            raise InputError(f"--brake {name}: the {robot.name}'s arm has no such joint; its joints: "
                             f"{', '.join(joints)}",
                             hint=f"did you mean {close[0]!r}?" if close else None)
    arm = SimulatedArm(robot, controller=args.controller, states=args.states, rate=args.rate,
                       prefix=args.prefix, brakes=args.brake, gui=args.gui)
    try:
        arm.run(args.seconds)
    except KeyboardInterrupt as stop:  # Ctrl-C, SIGTERM: leave the graph, close the simulation
        arm.say("stopped")
        return exit_code(stop)
    finally:
        arm.close()
    return 0
