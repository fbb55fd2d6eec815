"""The iCub URDF, generated at run time from the installed ``icub-models`` package.

``iCubGazeboV2_5`` is the model that renders in colour, but PyBullet cannot use it as shipped
(``getLinkState`` fails once its 212 links are loaded; docs/design.md §5).  This module
rewrites it into a cache folder:

- every fixed *leaf* link without a visual (skin patches, force sensors, IMUs, dh frames) is
  pruned, except ``r_hand_dh_frame`` which carries the pen; about 40 links remain;
- ``<gazebo>`` / ``<sensor>`` elements and the robot's collision shapes are dropped (the pen's
  contact with the paper is decided geometrically, see :mod:`hila_lang.robot.backend`);
- mass-less links get a tiny inertial (PyBullet would give each 1 kg);
- the legs and the left arm never move: their joints become fixed joints at the angles of
  :data:`FROZEN_POSTURE` (the left arm hangs slightly away from the body), which makes a
  simulation step about a third cheaper than holding them with motors;
- ``package://iCub/meshes`` paths become absolute, so the file may live anywhere;
- a pen is added, fixed in the right hand: it leaves the palm along +z of ``r_hand_dh_frame``
  and its tip (link ``pen_tip``) is :data:`PEN_LENGTH` along that axis;
- the eyes are added on ``head`` (no shipped model has eye links): an ``eyes_tilt`` joint and
  two camera frames ``l_eye_camera`` / ``r_eye_camera`` placed from the published iCub eye
  kinematics (iKin ``iCubEye``: eyes 0.068 m apart, about 0.10 m above the neck yaw axis).
  iKin puts the eye centres about 0.054 m in front of that axis, which is inside the model's
  closed head shell, so the optical centres sit at 0.078 m, just in front of the face (measured
  from the head mesh: its front surface is at 0.070 m at eye height).  Camera frames follow the
  OpenCV convention: +z is the optical axis, +x the image's right, +y the image's down.

Head frame, for the record (measured): with all joints at zero, ``head`` has +x to the robot's
left, +y up and +z forward.
"""

from __future__ import annotations

import hashlib
import math
import sys
import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path

from ..core.errors import HilaError
from ..core.fileio import atomic_write_text, cache_folders
from . import REACH

#: the icub-models robot used
ROBOT_NAME = "iCubGazeboV2_5"
#: world position of the root link (the waist), metres
ROOT_POSITION = (0.0, 0.0, 0.62)
#: yaw of the root link about +z, radians: with pi the robot faces +x, its right side is -y
ROOT_YAW = math.pi
#: pen length from the palm frame ``r_hand_dh_frame`` to the tip, metres
PEN_LENGTH = 0.10
#: pen radius (visual only), metres
PEN_RADIUS = 0.005

TORSO_JOINTS = ("torso_pitch", "torso_roll", "torso_yaw")
RIGHT_ARM_JOINTS = (
    "r_shoulder_pitch",
    "r_shoulder_roll",
    "r_shoulder_yaw",
    "r_elbow",
    "r_wrist_prosup",
    "r_wrist_pitch",
    "r_wrist_yaw",
)
#: the joints the IK moves, in chain order (root to hand)
ARM_CHAIN = TORSO_JOINTS + RIGHT_ARM_JOINTS
#: the end-effector link
PEN_TIP_LINK = "pen_tip"
EYE_LINKS = {"left": "l_eye_camera", "right": "r_eye_camera"}
EYES_TILT_JOINT = "eyes_tilt"

#: eye camera frames in the ``head`` frame (x left, y up, z forward), metres
EYE_BASELINE = 0.068
EYE_HEIGHT = 0.10
EYE_FORWARD = 0.078
#: eyes tilt limits, radians (positive looks up, as on the iCub)
EYES_TILT_LIMITS = (-math.radians(35.0), math.radians(15.0))

#: angles (radians) at which the legs' and left arm's joints are frozen; unlisted ones at 0
FROZEN_POSTURE = {"l_shoulder_pitch": -0.30, "l_shoulder_roll": 0.45, "l_elbow": 0.80}
#: name prefixes of the joints frozen into fixed joints
FROZEN_PREFIXES = ("l_hip", "l_knee", "l_ankle", "r_hip", "r_knee", "r_ankle", "l_shoulder", "l_elbow", "l_wrist")

#: maximum joint torques used by the position controllers, N m.  The URDF's efforts (50000)
#: are placeholders; these are of the order of the iCub's rated torques.
FORCE_LIMITS = {
    "torso_pitch": 80.0,
    "torso_roll": 60.0,
    "torso_yaw": 40.0,
    "r_shoulder_pitch": 30.0,
    "r_shoulder_roll": 30.0,
    "r_shoulder_yaw": 20.0,
    "r_elbow": 20.0,
    "r_wrist_prosup": 5.0,
    "r_wrist_pitch": 4.0,
    "r_wrist_yaw": 4.0,
}
#: force limit for every other (held) joint, N m
HOLD_FORCE = 40.0
#: torso comfort range for the IK, radians: (pitch, roll, yaw) lower and upper
TORSO_COMFORT = ((-0.10, -0.35, -0.60), (0.60, 0.35, 0.60))
#: relative IK weight of torso joints (they move less than the arm)
TORSO_WEIGHT = 0.3
#: seed posture of torso + right arm for the first IK (hand in front, palm down), radians
SEED_POSTURE = (0.10, 0.20, 0.0, -0.55, 0.60, 0.55, 1.30, 0.50, -0.10, 0.0)
#: rest posture of torso + right arm (hand by the side, out of the cameras' way), radians
REST_POSTURE = (0.0, 0.0, 0.0, -0.30, 0.45, 0.0, 0.80, 0.0, 0.0, 0.0)
#: the robot's prior for the table before it has seen it: this far below its waist, metres
#: (only a start for reading the first images; the plane is then triangulated)
TABLE_PRIOR_BELOW_ROOT = 0.15

_KEEP_LEAVES = {"r_hand_dh_frame"}
_TINY_INERTIAL = (
    '<inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="0.001"/>'
    '<inertia ixx="1e-7" ixy="0" ixz="0" iyy="1e-7" iyz="0" izz="1e-7"/></inertial>'
)
_GENERATOR_VERSION = "5"


class ModelError(HilaError):
    """The iCub model cannot be found or generated (icub-models missing or broken)."""


def source_urdf() -> Path:
    """Path of the shipped ``model.urdf`` of :data:`ROBOT_NAME` inside ``icub-models``."""
    try:
        # lazy: loads icub_models, which importing this module does not
        import icub_models
    except ImportError:
        raise ModelError(
            "the icub-models package is not installed", hint="pip install icub-models"
        ) from None
    try:
        return Path(icub_models.get_model_file(ROBOT_NAME))
    except FileNotFoundError:
        raise ModelError(f"icub-models has no {ROBOT_NAME} model") from None


def generate_urdf(source: Path | None = None) -> str:
    """The pruned, pen- and eye-equipped URDF as text (see the module docstring)."""
    source = source or source_urdf()
    meshes = (source.parent.parent.parent / "meshes").resolve()
    try:
        tree = ET.parse(source)
    except (OSError, ET.ParseError) as exc:
        raise ModelError(f"cannot read {source}: {exc}") from None
    robot = tree.getroot()
    for element in list(robot):
        if element.tag not in ("link", "joint"):
            robot.remove(element)
    _prune_leaves(robot)
    _freeze(robot)
    for link in robot.findall("link"):
        for collision in link.findall("collision"):
            link.remove(collision)
        for mesh in link.iter("mesh"):
            name = mesh.get("filename", "")
            if name.startswith("package://iCub/meshes/"):
                mesh.set("filename", str(meshes / name[len("package://iCub/meshes/"):]))
        if link.find("inertial") is None:
            link.insert(0, ET.fromstring(_TINY_INERTIAL))
    _add_pen(robot)
    _add_eyes(robot)
    ET.indent(tree)
    return ET.tostring(robot, encoding="unicode")


def _prune_leaves(robot: ET.Element) -> None:
    while True:
        links = {link.get("name"): link for link in robot.findall("link")}
        joints = robot.findall("joint")
        parents = {j.find("parent").get("link") for j in joints}
        doomed = {
            name
            for name, link in links.items()
            if link.find("visual") is None and name not in parents and name not in _KEEP_LEAVES
        }
        if not doomed:
            return
        for name in doomed:
            robot.remove(links[name])
        for joint in joints:
            if joint.find("child").get("link") in doomed:
                robot.remove(joint)


def _freeze(robot: ET.Element) -> None:
    # lazy: loads numpy, which importing this module does not
    from ..core.rotation import from_axis_angle, from_rpy, to_rpy

    for joint in robot.findall("joint"):
        name = joint.get("name")
        if joint.get("type") != "revolute" or not name.startswith(FROZEN_PREFIXES):
            continue
        origin = joint.find("origin")
        rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
        axis = [float(v) for v in joint.find("axis").get("xyz").split()]
        norm = math.sqrt(sum(a * a for a in axis))
        rotation = from_rpy(rpy) @ from_axis_angle([a / norm for a in axis], FROZEN_POSTURE.get(name, 0.0))
        origin.set("rpy", _fmt(to_rpy(rotation)))
        joint.set("type", "fixed")
        for tag in ("axis", "limit", "dynamics"):
            for element in joint.findall(tag):
                joint.remove(element)


def _link(name: str, visual: str = "") -> ET.Element:
    return ET.fromstring(f'<link name="{name}">{_TINY_INERTIAL}{visual}</link>')


def _fixed(name: str, parent: str, child: str, xyz, rpy=(0.0, 0.0, 0.0)) -> ET.Element:
    return ET.fromstring(
        f'<joint name="{name}" type="fixed"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/></joint>'
    )


def _fmt(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _add_pen(robot: ET.Element) -> None:
    body = (
        f'<visual><origin xyz="0 0 {PEN_LENGTH / 2 - 0.005}" rpy="0 0 0"/>'
        f'<geometry><cylinder radius="{PEN_RADIUS}" length="{PEN_LENGTH - 0.01}"/></geometry>'
        '<material name="pen_body"><color rgba="0.1 0.2 0.8 1"/></material></visual>'
    )
    tip = (
        '<visual><origin xyz="0 0 -0.005" rpy="0 0 0"/>'
        f'<geometry><cylinder radius="{PEN_RADIUS * 0.5}" length="0.01"/></geometry>'
        '<material name="pen_tip"><color rgba="0.05 0.05 0.1 1"/></material></visual>'
    )
    robot.append(_link("pen", body))
    robot.append(_fixed("pen_fixed_joint", "r_hand_dh_frame", "pen", (0, 0, 0)))
    robot.append(_link(PEN_TIP_LINK, tip))
    robot.append(_fixed("pen_tip_fixed_joint", "pen", PEN_TIP_LINK, (0, 0, PEN_LENGTH)))


def _add_eyes(robot: ET.Element) -> None:
    lo, hi = EYES_TILT_LIMITS
    robot.append(_link("eyes_tilt_link"))
    robot.append(
        ET.fromstring(
            f'<joint name="{EYES_TILT_JOINT}" type="revolute"><parent link="head"/>'
            f'<child link="eyes_tilt_link"/><origin xyz="0 {EYE_HEIGHT} {EYE_FORWARD}" rpy="0 0 0"/>'
            f'<axis xyz="-1 0 0"/><limit lower="{lo!r}" upper="{hi!r}" effort="10" velocity="5"/>'
            "</joint>"
        )
    )
    # camera frame: +z forward (head +z), +x right (head -x), +y down (head -y): rz(pi)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        name = EYE_LINKS[side]
        robot.append(_link(name))
        robot.append(
            _fixed(f"{name}_fixed_joint", "eyes_tilt_link", name, (sign * EYE_BASELINE / 2, 0, 0), (0, 0, math.pi))
        )


def spec():
    """The iCub's :class:`~hila_lang.robot.spec.RobotSpec`: this module's facts as a robot
    description (its URDF generated here, its eyes in its head, its reach declared in
    :data:`hila_lang.robot.REACH` and recomputed from the chain by ``tests/test_reach.py``)."""
    # lazy: loads numpy, which importing this module does not
    from .spec import RobotSpec

    return RobotSpec(
        name="icub", doc="the iCub (icub-models iCubGazeboV2_5): torso + right arm, eyes in its head",
        urdf=Path(f"icub-models:{ROBOT_NAME}"), tip="r_hand_dh_frame", base_link="root_link",
        base_position=ROOT_POSITION, base_yaw=ROOT_YAW, pen_length=PEN_LENGTH,
        seed=SEED_POSTURE, rest=REST_POSTURE,
        weights=dict.fromkeys(TORSO_JOINTS, TORSO_WEIGHT),
        comfort={n: (lo, hi) for n, lo, hi in zip(TORSO_JOINTS, *TORSO_COMFORT)},
        forces=dict(FORCE_LIMITS), hold_force=HOLD_FORCE,
        table_prior=ROOT_POSITION[2] - TABLE_PRIOR_BELOW_ROOT, eyes="head",
        outline_radius=0.045, pedestal=False, source="hila_lang/robot/model.py",
        generator=urdf_path, pen_tip_link=PEN_TIP_LINK, declared_reach=REACH)


@lru_cache(maxsize=None)
def urdf_path() -> Path:
    """Path of the generated URDF, written once into the cache folder and reused.

    The file name carries a hash of its contents, so a new icub-models or a new generator
    writes a new file.  The cache folder is ``$HILA_CACHE_DIR/hila/robot`` or
    ``~/.cache/hila/robot``; when it is not writable a temporary folder is used.
    """
    text = generate_urdf()
    digest = hashlib.sha256((_GENERATOR_VERSION + text).encode()).hexdigest()[:12]
    name = f"{ROBOT_NAME}_hila_{digest}.urdf"
    for folder in cache_folders("robot"):
        path = folder / name
        if path.is_file():
            try:
                if path.read_text(encoding="utf-8") == text:
                    return path
            except (OSError, UnicodeDecodeError):
                pass
            print(f"note: the cached robot model {path} is damaged (not what hila generates); "
                  "writing it again", file=sys.stderr)
        try:
            return atomic_write_text(path, text)
        except OSError:
            continue
    raise ModelError("cannot write the generated iCub URDF to a cache or temporary folder")
