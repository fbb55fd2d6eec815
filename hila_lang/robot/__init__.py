"""Robots in PyBullet -- the iCub, the Panda, the KUKA, any arm from its URDF -- behind one back end, and the dry back end.

- :mod:`hila_lang.robot.spec`      a robot as a declared description (:class:`RobotSpec`), ``--robot NAME|PATH``
- :mod:`hila_lang.robot.urdf`      any arm's URDF made ready: its chain checked, ``package://`` meshes found, a pen
- :mod:`hila_lang.robot.model`     the iCub's spec and its URDF generated at run time from ``icub-models``
- :mod:`hila_lang.robot.ik`        forward kinematics, Jacobian, damped least squares IK
- :mod:`hila_lang.robot.trajectory` densifying paths, trapezoidal speed profile
- :mod:`hila_lang.robot.workspace` the table in front of the robot; the default sheet of paper
- :mod:`hila_lang.robot.body`      a robot loaded in a simulated scene: joints, links, chains
- :mod:`hila_lang.robot.arm`       the arm controller: IK along a path, the 240 Hz control loop
- :mod:`hila_lang.robot.eyes`      the iCub's gaze and eye cameras (the ``eyes`` capability)
- :mod:`hila_lang.robot.rig`       eyes for an arm without a head: a stereo rig on a stand
- :mod:`hila_lang.robot.paper`     ink on the paper (``ink``), the camera above it (``overview``)
- :mod:`hila_lang.robot.backend`   :class:`PyBulletBackend`, the thin façade the interpreter drives
- :mod:`hila_lang.robot.dry`       :class:`DryBackend`: kinematic, no physics
- :mod:`hila_lang.robot.streaming` following a path whose tail changes while the arm moves (``streaming``)
- :mod:`hila_lang.robot.reach`     the arm's reach without a simulator, the checks of a planned path
- :mod:`hila_lang.robot.lens`      the eyes' fish-eye lenses and the robot's own calibration of them
- :mod:`hila_lang.robot.window`    the PyBullet window of a run with ``--gui``
- :mod:`hila_lang.robot.kinematic_arm` the arm as its description gives it: joints, FK/IK, limits, speed caps

The robot knows a neutral drawing surface (:class:`hila_lang.sim.surface.Surface`): what is
printed on it is a world's business.  ``DRY`` and ``PYBULLET`` declare the two back ends (entry
points ``hila.backends``); ``ICUB``, ``PANDA`` and ``KUKA`` the shipped robots
(``hila.robots``).  Importing this package imports nothing heavy; pybullet is loaded by
``backend``.
"""

from ..plugins.registry import BackendInfo, RobotInfo
from ..plugins.settings import Setting, number, point

#: the iCub arm's kinematic reach bound (:mod:`hila_lang.robot.reach`; kept here as numbers so
#: declaring the back ends imports nothing): the torso pitch origin and the chain's length, metres
REACH = ((0.0, -0.0270463, 0.62), 0.776)

DRY = BackendInfo(
    name="dry",
    factory="hila_lang.robot.dry:make_backend",
    doc="kinematic, no physics: the hand follows every path exactly",
    settings=(Setting("hand", "where the hand starts when the world does not say", point, metavar="X,Y,Z"),),
    reach=REACH,  # it checks planned paths as PyBullet's arm does
    streaming=True,  # its hand follows a changing path too (:mod:`hila_lang.robot.streaming`), deterministically
)

PYBULLET = BackendInfo(
    name="pybullet",
    factory="hila_lang.robot.backend:make_backend",
    doc="the iCub in PyBullet: IK, 240 Hz position control, ink on the paper, fish-eye eye cameras",
    settings=(Setting("eyes.noise", "sensor noise of the eye cameras: Gaussian, standard deviation in grey "
                                    "levels 0-255, seeded by --seed", number(0.0, 40.0), default=0.0,
                      metavar="SIGMA"),
              Setting("speed", "with --gui: play the motion N times faster than real time (the simulation is the "
                               "same; headless runs are not paced)", number(0.1, 100.0), default=1.0, metavar="N",
                      flag="--speed"),),
    reach=REACH,
    streaming=True,  # the arm retargets inside its 240 Hz loop (:mod:`hila_lang.robot.streaming`)
)

ICUB = RobotInfo(name="icub", factory="hila_lang.robot.model:spec",
                 doc="the iCub: torso + right arm (10 joints), eyes in its head (the default)")
PANDA = RobotInfo(name="panda", factory="hila_lang.robot.spec:panda",
                  doc="Franka Emika Panda (7 joints, pybullet_data), a stereo rig on a stand")
KUKA = RobotInfo(name="kuka", factory="hila_lang.robot.spec:kuka",
                 doc="KUKA LBR iiwa (7 joints, pybullet_data), a stereo rig on a stand")
