"""Any arm's URDF made ready for hila: its chain checked, its meshes found, a pen in its hand.

:func:`prepare` turns the URDF a robot's spec names (:mod:`.spec`) into the file PyBullet
loads, written once into the cache folder (``$HILA_CACHE_DIR/hila/robot``, as the iCub's
generated model, :mod:`.model`):

- the chain from the base link to the flange (``tip``) is found (:func:`chain_joints`); a tip
  that is not a link, a tip not below the base, a joint on the way that is neither revolute,
  continuous nor fixed, or fewer than :data:`MIN_JOINTS` movable joints is an
  :class:`~hila_lang.core.errors.InputError` naming the URDF file and the line of the link or
  joint at fault;
- every mesh is resolved to an absolute path (:func:`resolve_mesh`): ``package://PKG/REST`` is
  looked for as ``DIR/PKG/REST`` and ``DIR/REST`` in the URDF's folder and its parents, then in
  the spec's ``packages`` folders (``--set robot.packages=DIR[:DIR]``), then in
  ``ROS_PACKAGE_PATH``; a relative file name is relative to the URDF's folder.  A mesh found
  nowhere is one line naming it, the link and the folders searched;
- movable joints off the chain (fingers, a second arm) become fixed at the spec's ``frozen``
  angles (0 unless given), which makes a simulation step cheaper and holds them still;
- ``<gazebo>``, ``<transmission>`` and the robot's collision shapes are dropped (the pen's
  contact with the paper is decided geometrically, as for the iCub); mass-less links get a tiny
  inertial (PyBullet would give each 1 kg);
- a pen is fixed to the flange along the spec's pen axis, its tip a link named
  :data:`PEN_TIP_LINK` whose +z is the pen's axis (what the IK keeps pointing down).
"""

from __future__ import annotations

import hashlib
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..core.errors import did_you_mean, HilaRuntimeError, InputError
from ..core.fileio import atomic_write_text, cache_folders
from ..core.rotation import from_axis_angle, from_rpy, to_rpy

#: the pen tip's link in a prepared URDF
PEN_TIP_LINK = "hila_pen_tip"
#: a chain with fewer movable joints than this cannot hold a pen vertical over a table
MIN_JOINTS = 3
#: joint types the IK moves
MOVABLE = ("revolute", "continuous")
#: limits given to a continuous joint, radians: a whole turn each way, so the IK can follow a
#: path across +-pi without a jump
CONTINUOUS_LIMIT = 2 * math.pi
PEN_RADIUS = 0.005
TINY_INERTIAL = (
    '<inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="0.001"/>'
    '<inertia ixx="1e-7" ixy="0" ixz="0" iyy="1e-7" iyz="0" izz="1e-7"/></inertial>'
)
_VERSION = "1"


def fmt(values) -> str:
    """Numbers as URDF writes them: ``"0.1 0.0 -0.2"``."""
    return " ".join(repr(float(v)) for v in values)


def _line_of(text: str, tag: str, name: str) -> int | None:
    """The 1-based line of ``<tag name="NAME"`` in ``text`` (for a located error), or None."""
    for quote in ('"', "'"):
        k = text.find(f'<{tag} name={quote}{name}{quote}')
        if k >= 0:
            return text.count("\n", 0, k) + 1
    return None


def read(path: Path) -> tuple[ET.Element, str]:
    """The URDF's root element and text; an unreadable or malformed file is an InputError
    naming it (and the line of a syntax error)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the robot's URDF: {exc.strerror if isinstance(exc, OSError) else exc}",
                         file=str(path)) from None
    try:
        robot = ET.fromstring(text)
    except ET.ParseError as exc:
        line, column = exc.position
        raise InputError(f"the robot's URDF is not well-formed XML ({exc.msg if hasattr(exc, 'msg') else exc})",
                         file=str(path), line=line, column=column + 1) from None
    if robot.tag != "robot":
        raise InputError(f"not a URDF: the top element is <{robot.tag}>, expected <robot>", file=str(path))
    return robot, text


def root_link(robot: ET.Element, path: Path) -> str:
    """The URDF's root link (the one link that is no joint's child)."""
    links = [link.get("name") for link in robot.findall("link")]
    children = {j.find("child").get("link") for j in robot.findall("joint") if j.find("child") is not None}
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise InputError(f"the URDF has {len(roots)} root links ({', '.join(roots) or 'none'}); expected one",
                         file=str(path))
    return roots[0]


def chain_joints(robot: ET.Element, text: str, path: Path, base: str, tip: str, *, tip_flag: str = "tip") -> list:
    """The joint elements from ``base`` down to ``tip``, root first; the refusals of the module
    docstring, each an InputError located in the URDF."""
    links = [link.get("name") for link in robot.findall("link")]
    if tip not in links:
        close = did_you_mean(tip, links)
        raise InputError(f"the robot's {tip_flag} {tip!r} is not a link of the URDF (it has {len(links)} links)",
                         file=str(path), hint=close or f"links: {', '.join(links[:12])}" + (" ..." if len(links) > 12 else ""))
    if base not in links:
        raise InputError(f"the robot's base link {base!r} is not a link of the URDF", file=str(path),
                         hint=did_you_mean(base, links))
    by_child = {j.find("child").get("link"): j for j in robot.findall("joint") if j.find("child") is not None}
    path_joints, link = [], tip
    while link != base:
        if link not in by_child:
            raise InputError(f"no serial chain from the base link {base!r} to the {tip_flag} {tip!r}: {tip!r} is "
                             f"not below {base!r} (the chain ends at {link!r})",
                             file=str(path), line=_line_of(text, "link", tip))
        joint = by_child[link]
        path_joints.append(joint)
        link = joint.find("parent").get("link")
    path_joints.reverse()
    for joint in path_joints:
        kind = joint.get("type")
        if kind not in (*MOVABLE, "fixed"):
            raise InputError(f"joint {joint.get('name')!r} on the chain to {tip!r} is {kind}: hila's arm moves "
                             "revolute and continuous joints only", file=str(path),
                             line=_line_of(text, "joint", joint.get("name")))
        if kind == "revolute":
            limit = joint.find("limit")
            if limit is None or limit.get("lower") is None or limit.get("upper") is None:
                raise InputError(f"revolute joint {joint.get('name')!r} has no <limit lower=... upper=...>",
                                 file=str(path), line=_line_of(text, "joint", joint.get("name")))
    movable = [j for j in path_joints if j.get("type") in MOVABLE]
    if len(movable) < MIN_JOINTS:
        raise InputError(f"the chain from {base!r} to {tip!r} has {len(movable)} movable joint"
                         f"{'s' if len(movable) != 1 else ''}; an arm that holds a pen needs at least {MIN_JOINTS}",
                         file=str(path), line=_line_of(text, "link", tip),
                         hint=f"name a link farther out with --set robot.{tip_flag.split()[-1]}=LINK")
    return path_joints


def search_path(urdf: Path, packages=()) -> list[Path]:
    """Where ``package://`` meshes are looked for, in order: the URDF's folder and its parents,
    ``packages``, then ``ROS_PACKAGE_PATH``."""
    here = Path(urdf).resolve().parent
    folders = [here, *here.parents]
    folders += [Path(p).expanduser() for p in packages]
    folders += [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
    return folders


def resolve_mesh(name: str, urdf: Path, folders) -> Path | None:
    """The file a URDF mesh ``filename`` names (``package://``, ``file://``, relative or
    absolute), or None when it is nowhere on ``folders`` (:func:`search_path`)."""
    if name.startswith("file://"):
        candidate = Path(name[7:])
        return candidate if candidate.is_file() else None
    if name.startswith("package://"):
        rest = name[len("package://"):]
        package, _, inner = rest.partition("/")
        for folder in folders:
            for candidate in (folder / package / inner, folder / inner):
                if candidate.is_file():
                    return candidate.resolve()
            if folder.name == package and (folder / inner).is_file():
                return (folder / inner).resolve()
        return None
    candidate = Path(name) if Path(name).is_absolute() else Path(urdf).resolve().parent / name
    return candidate.resolve() if candidate.is_file() else None


def resolve_meshes(robot: ET.Element, urdf: Path, packages) -> None:
    """Point every mesh of ``robot`` (the URDF's root element) at its file (:func:`resolve_mesh`);
    the first one found nowhere is an InputError naming it, its link and where it was looked for."""
    folders = search_path(urdf, packages)
    for link in robot.findall("link"):
        for mesh in link.iter("mesh"):
            name = mesh.get("filename", "")
            found = resolve_mesh(name, urdf, folders)
            if found is None:
                shown = ", ".join(str(f) for f in folders[:3]) + (f" and {len(folders) - 3} more" if len(folders) > 3 else "")
                raise InputError(f"mesh {name!r} of link {link.get('name')!r} not found (looked in {shown})",
                                 file=str(urdf), hint="give the folder that holds its package with "
                                                      "--set robot.packages=DIR[:DIR] (or ROS_PACKAGE_PATH)")
            mesh.set("filename", str(found))


def _freeze(robot: ET.Element, keep: set[str], frozen: dict) -> None:
    for joint in robot.findall("joint"):
        name, kind = joint.get("name"), joint.get("type")
        if kind == "fixed" or name in keep:
            continue
        origin = joint.find("origin")
        if origin is None:
            origin = ET.SubElement(joint, "origin")
        xyz = np.array([float(v) for v in origin.get("xyz", "0 0 0").split()])
        rpy = [float(v) for v in origin.get("rpy", "0 0 0").split()]
        axis_el = joint.find("axis")
        axis = np.array([float(v) for v in (axis_el.get("xyz") if axis_el is not None else "1 0 0").split()])
        axis = axis / np.linalg.norm(axis)
        value = float(frozen.get(name, 0.0))
        if kind in MOVABLE:
            origin.set("rpy", fmt(to_rpy(from_rpy(rpy) @ from_axis_angle(axis, value))))
        elif kind == "prismatic":
            origin.set("xyz", fmt(xyz + from_rpy(rpy) @ (axis * value)))
        joint.set("type", "fixed")
        for tag in ("axis", "limit", "dynamics", "mimic", "calibration", "safety_controller"):
            for element in joint.findall(tag):
                joint.remove(element)


def _pen_rotation(axis) -> np.ndarray:
    """A rotation (3, 3) whose +z is ``axis`` (the pen's direction in the flange's frame)."""
    z = np.asarray(axis, dtype=float)
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def add_pen(robot: ET.Element, flange: str, length: float, axis=(0.0, 0.0, 1.0), offset=(0.0, 0.0, 0.0),
            *, pen: str = "hila_pen", tip: str = PEN_TIP_LINK) -> None:
    """Fix a pen ``length`` metres long to ``flange``, from ``offset`` (flange frame) along
    ``axis``; its tip is link ``tip`` with +z along the pen."""
    rpy = to_rpy(_pen_rotation(axis))
    body = (f'<visual><origin xyz="0 0 {length / 2 - 0.005}" rpy="0 0 0"/>'
            f'<geometry><cylinder radius="{PEN_RADIUS}" length="{length - 0.01}"/></geometry>'
            '<material name="pen_body"><color rgba="0.1 0.2 0.8 1"/></material></visual>')
    point = ('<visual><origin xyz="0 0 -0.005" rpy="0 0 0"/>'
             f'<geometry><cylinder radius="{PEN_RADIUS * 0.5}" length="0.01"/></geometry>'
             '<material name="pen_tip"><color rgba="0.05 0.05 0.1 1"/></material></visual>')
    robot.append(ET.fromstring(f'<link name="{pen}">{TINY_INERTIAL}{body}</link>'))
    robot.append(ET.fromstring(f'<joint name="{pen}_fixed_joint" type="fixed"><parent link="{flange}"/>'
                               f'<child link="{pen}"/><origin xyz="{fmt(offset)}" rpy="{fmt(rpy)}"/></joint>'))
    robot.append(ET.fromstring(f'<link name="{tip}">{TINY_INERTIAL}{point}</link>'))
    robot.append(ET.fromstring(f'<joint name="{tip}_fixed_joint" type="fixed"><parent link="{pen}"/>'
                               f'<child link="{tip}"/><origin xyz="0 0 {float(length)!r}" rpy="0 0 0"/></joint>'))


def prepared_text(spec) -> str:
    """The URDF of ``spec`` (a :class:`~.spec.RobotSpec` naming a URDF file) made ready, as text
    (see the module docstring)."""
    robot, text = read(spec.urdf)
    joints = chain_joints(robot, text, spec.urdf, spec.base_link, spec.tip, tip_flag="tip")
    for element in list(robot):
        if element.tag not in ("link", "joint", "material"):
            robot.remove(element)
    resolve_meshes(robot, spec.urdf, spec.packages)
    _freeze(robot, {j.get("name") for j in joints if j.get("type") in MOVABLE}, dict(spec.frozen))
    for link in robot.findall("link"):
        for collision in link.findall("collision"):
            link.remove(collision)
        inertial = link.find("inertial")
        mass = None if inertial is None or inertial.find("mass") is None else float(inertial.find("mass").get("value", 0))
        if inertial is None or not mass:
            if inertial is not None:
                link.remove(inertial)
            link.insert(0, ET.fromstring(TINY_INERTIAL))
    if PEN_TIP_LINK in {link.get("name") for link in robot.findall("link")}:
        raise InputError(f"the URDF already has a link named {PEN_TIP_LINK!r}, the name hila gives its pen's tip",
                         file=str(spec.urdf))
    add_pen(robot, spec.tip, spec.pen_length, spec.pen_axis, spec.pen_offset)
    ET.indent(robot)
    return ET.tostring(robot, encoding="unicode")


def prepare(spec) -> Path:
    """Path of ``spec``'s prepared URDF, written once into the cache folder and reused (its name
    carries a hash of its text)."""
    text = prepared_text(spec)
    digest = hashlib.sha256((_VERSION + text).encode()).hexdigest()[:12]
    name = f"{spec.name}_hila_{digest}.urdf"
    for folder in cache_folders("robot"):
        target = folder / name
        try:
            if target.is_file() and target.read_text(encoding="utf-8") == text:
                return target
            return atomic_write_text(target, text)
        except (OSError, UnicodeDecodeError):
            continue
    raise HilaRuntimeError(f"cannot write the prepared URDF of robot {spec.name!r} to a cache or temporary folder")
