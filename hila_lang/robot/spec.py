"""A robot is a declared description: :class:`RobotSpec`, read from a YAML file or a bare URDF.

**The API** (what the back ends, ``hila check`` and ``hila robot-sim`` read; keep it small):

- ``name``, ``doc``; ``urdf`` (the source file) and :meth:`RobotSpec.urdf_path` (the file
  PyBullet loads: the source made ready by :mod:`.urdf`, or the iCub's generated model);
- ``base_link``, ``tip`` (the flange) and :meth:`RobotSpec.chain` (a
  :class:`~.ik.KinematicChain` from the world to the pen's tip: the joint names, their
  position limits; ``chain().tip`` folds the flange-to-tip *tool* transform in, and
  :meth:`RobotSpec.tool` gives it alone); :meth:`RobotSpec.limits` adds each joint's velocity
  and effort;
- ``base_position`` / ``base_yaw`` and :meth:`RobotSpec.world_T_base` (where the base stands
  at hila's table, world frame);
- ``pen_length``, ``pen_axis``, ``pen_offset``: the tool, in the flange's frame;
- ``seed``, ``rest`` (postures, chain order), ``weights`` and ``comfort`` (the IK's), ``forces``
  (N m, the position controllers' limits), ``frozen`` (angles of the joints off the chain);
- ``sheet_center`` / ``sheet_rotation`` (where the default sheet lies), ``table_prior`` (the
  table height the robot assumes before its eyes have measured it);
- ``eyes``: ``"head"`` (the iCub's) or a :class:`RigSpec` (two cameras on a stand);
- :meth:`RobotSpec.reach`: the reach ball computed from the chain.

**hila's table.**  Every robot stands at the same table (:mod:`.workspace`: top at z = 0.57 m,
front edge at x = 0.12 m, the robot on the -x side facing +x, its right towards -y): the worlds
lay their sheets on it, and a spec says where the robot's base is.  The shipped arms stand on a
pedestal 2 cm below the table top, behind its front edge.

**Finding a robot** (:func:`resolve`): a registered name (entry points ``hila.robots``: ``icub``,
``panda``, ``kuka``; another package adds its own), a spec file (``.yaml``), or a bare URDF
(``.urdf``) with the stated defaults of :func:`bare_spec`.  ``--set robot.KEY=VALUE`` changes a
spec: :data:`OVERRIDES`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import did_you_mean, InputError
from ..core.fileio import load_yaml
from ..core.rotation import about_z, pose
from ..plugins import registry
from ..plugins.options import parse_pairs
from . import ik
from .urdf import _pen_rotation, MOVABLE, PEN_TIP_LINK, prepare, read, resolve_meshes, root_link
from .workspace import default_surface, READY_HEIGHT, TABLE_TOP_Z

#: the robot of a run that names none
DEFAULT_ROBOT = "icub"
#: what ``--set robot.KEY=VALUE`` may change
OVERRIDES = {
    "tip": "the flange link the pen is fixed to (a bare URDF: default the end of its longest chain)",
    "packages": "folders (DIR[:DIR]) where package:// meshes are looked for, before ROS_PACKAGE_PATH",
    "base": "where the robot's base stands, X,Y,Z metres (world frame)",
    "pen": "the pen's length from the flange, metres",
}
#: the keys a spec file may have
SPEC_KEYS = ("name", "doc", "urdf", "base_link", "tip", "pen", "base", "seed", "rest", "weights", "comfort",
             "forces", "frozen", "sheet", "table_prior", "eyes", "packages", "outline_radius")
#: a bare URDF's base: this far below the table top (a pedestal), metres
PEDESTAL_BELOW_TABLE = 0.02
#: a bare URDF's base stands so far behind the sheet's centre, as a share of its reach radius
#: (kept within :data:`BASE_DISTANCE`): half-way out is where a pen held vertical moves most freely
BASE_REACH_SHARE = 0.5
BASE_DISTANCE = (0.30, 0.60)
#: a bare URDF's pen length, metres (as the iCub's)
DEFAULT_PEN = 0.10
#: a rig's left camera relative to the sheet's centre when the spec does not place it, metres
#: (why there: :mod:`.rig`)
RIG_OFFSET = np.array([-0.25, 0.30, 0.50])


@dataclass(frozen=True)
class RigSpec:
    """Two cameras on a stand beside the table (:mod:`.rig`): the left camera's optical centre
    at ``position`` (world, metres), both looking at ``look_at``, the right one ``baseline``
    metres to the left camera's right."""

    position: tuple[float, float, float]
    look_at: tuple[float, float, float]
    baseline: float = 0.10


@dataclass(frozen=True)
class RobotSpec:
    """One robot (see the module docstring).  Postures are in chain order (root to tip)."""

    name: str
    urdf: Path
    tip: str
    base_link: str
    doc: str = ""
    base_position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_yaw: float = 0.0
    pen_length: float = DEFAULT_PEN
    pen_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    pen_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    seed: tuple[float, ...] | None = None
    rest: tuple[float, ...] | None = None
    weights: dict = field(default_factory=dict)
    comfort: dict = field(default_factory=dict)
    forces: dict = field(default_factory=dict)
    frozen: dict = field(default_factory=dict)
    hold_force: float = 40.0
    sheet_center: tuple[float, float] = (0.31, -0.09)
    sheet_rotation: float = math.radians(15.0)
    table_prior: float = 0.47
    eyes: Any = None
    packages: tuple[str, ...] = ()
    outline_radius: float = 0.06
    #: the base stands on a pedestal from the floor (drawn; the iCub stands on its legs)
    pedestal: bool = True
    source: str = ""
    #: the iCub's own: its generated model (a callable -> Path), its pen tip's link and its
    #: declared reach ((x, y, z), radius); None for a robot made from its URDF
    generator: Any = None
    pen_tip_link: str | None = None
    declared_reach: tuple | None = None

    # -- frames --------------------------------------------------------------------------------
    def world_T_base(self) -> np.ndarray:
        """Where the base link stands, (4, 4) world frame."""
        return pose(about_z(self.base_yaw), self.base_position)

    def tool(self) -> np.ndarray:
        """``flange_T_tip`` (4, 4): the pen's tip in the flange's frame, +z along the pen."""
        rotation = _pen_rotation(self.pen_axis)
        return pose(rotation, np.asarray(self.pen_offset, float) + rotation[:, 2] * self.pen_length)

    def urdf_path(self) -> Path:
        """The URDF file PyBullet loads (made ready once and cached, :mod:`.urdf`)."""
        if self.generator is not None:
            return self.generator()

        return prepare(self)

    def tip_link(self) -> str:
        """The pen tip's link in :meth:`urdf_path`."""
        return self.pen_tip_link or PEN_TIP_LINK

    def chain(self):
        """The :class:`~.ik.KinematicChain` from the world to the pen's tip (read from the source
        URDF, the tool folded in; no file is written)."""
        return _chain(self)

    def limits(self) -> dict[str, dict[str, float]]:
        """Joint name -> ``lower``, ``upper`` (radians), ``velocity`` (rad/s), ``effort`` (N m,
        the spec's force limit, else the URDF's) for the chain's joints."""
        robot, _ = read(self.source_urdf())
        joints = {j.get("name"): j for j in robot.findall("joint")}
        chain = self.chain()
        out = {}
        for name, lo, hi in zip(chain.names, chain.lower, chain.upper):
            limit = joints[name].find("limit") if name in joints else None
            get = (lambda k, d: float(limit.get(k, d))) if limit is not None else (lambda k, d: float(d))
            out[name] = {"lower": float(lo), "upper": float(hi), "velocity": get("velocity", 2.0),
                         "effort": float(self.forces.get(name, get("effort", 50.0)))}
        return out

    def source_urdf(self) -> Path:
        """The URDF the chain is read from (the iCub's: its generated model)."""
        return self.urdf_path() if self.generator is not None else self.urdf

    # -- postures and the IK -------------------------------------------------------------------
    def posture(self, which: str) -> np.ndarray:
        """``"seed"`` or ``"rest"`` posture (n,), radians, chain order."""
        values = getattr(self, which)
        n = self.chain().dof
        if values is None:
            raise InputError(f"robot {self.name!r} has no {which} posture")
        if len(values) != n:
            raise InputError(f"robot {self.name!r}: its {which} posture has {len(values)} angles, its chain {n} joints",
                             file=self.source or None)
        return np.array(values, dtype=float)

    def joint_weights(self) -> np.ndarray:
        """The IK's weight of each joint (n,) (1 unless the spec says)."""
        return np.array([float(self.weights.get(n, 1.0)) for n in self.chain().names])

    def ik_limits(self, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """The IK's limits (n,) each: ``margin`` inside the URDF's, and within the comfort ranges."""
        chain = self.chain()
        lo, hi = chain.lower + margin, chain.upper - margin
        for i, name in enumerate(chain.names):
            if name in self.comfort:
                lo[i] = max(lo[i], self.comfort[name][0])
                hi[i] = min(hi[i], self.comfort[name][1])
        return lo, hi

    def force_limits(self) -> list[float]:
        """Force limits (N m) of the chain's joints, in chain order."""
        limits = self.limits()  # once: it parses the URDF
        return [limits[n]["effort"] for n in self.chain().names]

    # -- where -------------------------------------------------------------------------------
    def reach(self) -> tuple[tuple[float, float, float], float]:
        """A ball ((x, y, z), radius) that holds every point the pen's tip can reach: the first
        joint's origin and the sum of the distances between successive joint origins and on to
        the tip (each fixed by the links between them: the triangle inequality)."""
        if self.declared_reach is not None:
            return self.declared_reach
        return chain_reach(self.chain())

    def default_surface(self):
        """The sheet a world that says nothing gets (:func:`.workspace.default_surface`)."""
        return default_surface(self.sheet_center, self.sheet_rotation)

    def summary(self) -> str:
        (x, y, z), r = self.reach()
        chain = self.chain()
        eyes = "eyes in its head" if self.eyes == "head" else "a stereo rig on a stand" if self.eyes else "no eyes"
        return (f"{self.name}: {chain.dof} joints ({', '.join(chain.names)}), pen {self.pen_length:.3f} m from "
                f"{self.tip!r}, reach {r:.3f} m around ({x:.3f}, {y:.3f}, {z:.3f}), {eyes}")


def chain_reach(chain) -> tuple[tuple[float, float, float], float]:
    """The reach ball of a chain (see :meth:`RobotSpec.reach`)."""
    tip, positions, _ = chain.forward(np.zeros(chain.dof))
    points = np.vstack([positions, tip[:3, 3]])
    radius = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    return tuple(float(v) for v in positions[0]), radius


_CHAINS: dict = {}


def _chain(spec: RobotSpec):
    key = (spec.name, str(spec.urdf), spec.tip, spec.base_link, spec.base_position, spec.base_yaw, spec.pen_length,
           spec.pen_axis, spec.pen_offset, spec.generator)
    if key not in _CHAINS:
        if spec.generator is not None:
            text = spec.urdf_path().read_text(encoding="utf-8")
            _CHAINS[key] = ik.KinematicChain.from_urdf(text, spec.tip_link(), spec.world_T_base(), spec.base_link)
        else:
            # lazy: only this branch needs it
            from .urdf import chain_joints, read

            robot, text = read(spec.urdf)
            chain_joints(robot, text, spec.urdf, spec.base_link, spec.tip)
            chain = ik.KinematicChain.from_urdf(text, spec.tip, spec.world_T_base(), spec.base_link)
            _CHAINS[key] = replace(chain, tip=chain.tip @ spec.tool())
    return _CHAINS[key]


# -- reading specs ---------------------------------------------------------------------------
def _numbers(value, n: int | None, what: str, source: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in (value if isinstance(value, (list, tuple, np.ndarray)) else [value]))
    except (TypeError, ValueError):
        raise InputError(f"{what} must be numbers, got {value!r}", file=source or None) from None
    if (n is not None and len(out) != n) or not all(math.isfinite(v) for v in out):
        raise InputError(f"{what} must be {n or 'some'} finite numbers, got {value!r}", file=source or None)
    return out


def _pybullet_data(name: str) -> Path:
    # lazy: loads pybullet_data, which importing this module does not
    import pybullet_data

    return Path(pybullet_data.getDataPath()) / name


def _urdf_file(value: str, base: Path, source: str) -> Path:
    if not isinstance(value, str) or not value:
        raise InputError(f"urdf must name a file, got {value!r}", file=source or None)
    if value.startswith("pybullet_data:"):
        path = _pybullet_data(value.split(":", 1)[1])
    else:
        path = Path(value).expanduser()
        path = path if path.is_absolute() else base / path
    if not path.is_file():
        raise InputError(f"the robot's URDF {value!r} is not a file ({path})", file=source or None)
    return path


def _posture(value, names: dict, what: str, source: str):
    if value is None:
        return None
    if isinstance(value, dict):
        return ("by name", {str(k): float(v) for k, v in value.items()})
    return _numbers(value, None, what, source)


def spec_from_mapping(data: dict, *, base: Path, source: str, overrides: dict | None = None) -> RobotSpec:
    """A :class:`RobotSpec` from a spec file's mapping (``base``: the folder relative paths start from)."""
    if not isinstance(data, dict):
        raise InputError(f"a robot spec is a mapping of {', '.join(SPEC_KEYS)}; got {type(data).__name__}",
                         file=source or None)
    unknown = [k for k in data if k not in SPEC_KEYS]
    if unknown:
        # lazy: only this branch needs it
        from ..core.errors import did_you_mean

        raise InputError(f"unknown key {unknown[0]!r} in the robot spec; known: {', '.join(SPEC_KEYS)}",
                         file=source or None, hint=did_you_mean(str(unknown[0]), SPEC_KEYS))
    if "urdf" not in data:
        raise InputError("the robot spec names no urdf", file=source or None)
    urdf = _urdf_file(data["urdf"], base, source)
    overrides = dict(overrides or {})

    robot, _ = read(urdf)
    base_link = str(data.get("base_link") or root_link(robot, urdf))
    tip = str(overrides.pop("tip", None) or data.get("tip") or find_tip(robot, urdf, base_link))
    pen = data.get("pen") or {}
    if not isinstance(pen, dict):
        raise InputError("pen must be a mapping of length, axis, offset", file=source or None)
    where = data.get("base") or {}
    sheet = data.get("sheet") or {}
    kwargs: dict[str, Any] = dict(
        name=str(data.get("name") or urdf.stem), doc=str(data.get("doc") or ""), urdf=urdf, tip=tip,
        base_link=base_link, source=source,
        pen_length=float(pen.get("length", DEFAULT_PEN)),
        pen_axis=_numbers(pen.get("axis", (0, 0, 1)), 3, "pen.axis", source),
        pen_offset=_numbers(pen.get("offset", (0, 0, 0)), 3, "pen.offset", source),
        weights={str(k): float(v) for k, v in (data.get("weights") or {}).items()},
        comfort={str(k): _numbers(v, 2, f"comfort.{k}", source) for k, v in (data.get("comfort") or {}).items()},
        forces={str(k): float(v) for k, v in (data.get("forces") or {}).items()},
        frozen={str(k): float(v) for k, v in (data.get("frozen") or {}).items()},
        packages=tuple(str(Path(p) if Path(p).is_absolute() else base / p) for p in (data.get("packages") or ())),
        outline_radius=float(data.get("outline_radius", 0.06)),
    )
    if "position" in where:
        kwargs["base_position"] = _numbers(where["position"], 3, "base.position", source)
    if "yaw_deg" in where:
        kwargs["base_yaw"] = math.radians(float(where["yaw_deg"]))
    if "center" in sheet:
        kwargs["sheet_center"] = _numbers(sheet["center"], 2, "sheet.center", source)
    if "rotation_deg" in sheet:
        kwargs["sheet_rotation"] = math.radians(float(sheet["rotation_deg"]))
    if "table_prior" in data:
        kwargs["table_prior"] = float(data["table_prior"])
    eyes = data.get("eyes", "rig")
    spec = RobotSpec(**kwargs)
    spec = _apply_overrides(spec, overrides)
    resolve_meshes(robot, urdf, spec.packages)  # a missing mesh is refused now, before anything runs
    if "position" not in where and "base" not in overrides:
        spec = replace(spec, base_position=_default_base(spec))
    spec = replace(spec, eyes=_eyes(eyes, spec, source))
    names = spec.chain().names
    for key in ("weights", "comfort", "forces"):
        stray = [k for k in getattr(spec, key) if k not in names]
        if stray:
            raise InputError(f"{key} names {stray[0]!r}, not a joint of the chain ({', '.join(names)})",
                             file=source or None)
    seed = _posture(data.get("seed"), names, "seed", source)
    rest = _posture(data.get("rest"), names, "rest", source)
    seed = _by_name(seed, names) if seed is not None else None
    rest = _by_name(rest, names) if rest is not None else None
    if seed is None:
        seed = find_seed(spec)
    return replace(spec, seed=seed, rest=rest if rest is not None else seed)


def _by_name(value, names):
    if isinstance(value, tuple) and value and value[0] == "by name":
        return tuple(float(value[1].get(n, 0.0)) for n in names)
    return value


def _eyes(value, spec: RobotSpec, source: str):
    if value in (None, "none"):
        return None

    centre = np.array([*spec.sheet_center, TABLE_TOP_Z])
    if value == "rig":
        value = {}
    if not isinstance(value, dict):
        raise InputError(f"eyes must be 'rig', 'none' or a mapping of position, look_at, baseline; got {value!r}",
                         file=source or None)
    position = _numbers(value.get("position", centre + RIG_OFFSET), 3, "eyes.position", source)
    look = _numbers(value.get("look_at", centre), 3, "eyes.look_at", source)
    return RigSpec(position, look, float(value.get("baseline", 0.10)))


def _apply_overrides(spec: RobotSpec, overrides: dict) -> RobotSpec:
    changes: dict[str, Any] = {}
    for key, text in overrides.items():
        if key == "tip":
            changes["tip"] = str(text)
        elif key == "packages":
            changes["packages"] = tuple(p for p in str(text).split(os.pathsep) if p) + spec.packages
        elif key == "base":
            changes["base_position"] = _numbers(str(text).split(","), 3, "--set robot.base", "")
        elif key == "pen":
            value = _numbers(text, 1, "--set robot.pen", "")[0]
            if not 0.01 <= value <= 0.5:
                raise InputError(f"--set robot.pen={text}: a pen length from 0.01 to 0.5 m")
            changes["pen_length"] = value
    return replace(spec, **changes) if changes else spec


def find_tip(robot, urdf: Path, base: str) -> str:
    """A URDF's flange when none is named: the child of the movable joint with the most movable
    joints above it, then on down a lone fixed joint at a time (a flange or tool frame)."""
    by_child = {j.find("child").get("link"): j for j in robot.findall("joint") if j.find("child") is not None}
    best, count = None, -1
    for link in by_child:
        n, at = 0, link
        while at in by_child and at != base:
            n += by_child[at].get("type") in MOVABLE
            at = by_child[at].find("parent").get("link")
        if n > count and by_child[link].get("type") in MOVABLE:
            best, count = link, n
    if best is None:
        raise InputError("the URDF has no movable joint", file=str(urdf))
    while True:  # on to the flange frame: a single fixed joint below
        below = [j for j in robot.findall("joint") if j.find("parent") is not None and j.find("parent").get("link") == best]
        if len(below) != 1 or below[0].get("type") != "fixed":
            return best
        best = below[0].find("child").get("link")


def _default_base(spec: RobotSpec) -> tuple[float, float, float]:
    at_origin = replace(spec, base_position=(0.0, 0.0, 0.0), base_yaw=0.0)
    (_, _, _), radius = at_origin.reach()
    distance = min(max(BASE_REACH_SHARE * radius, BASE_DISTANCE[0]), BASE_DISTANCE[1])
    x, y = spec.sheet_center
    return (float(x - distance), float(y), TABLE_TOP_Z - PEDESTAL_BELOW_TABLE)


def find_seed(spec: RobotSpec, tries: int = 40) -> tuple[float, ...]:
    """A posture with the pen vertical above the sheet's centre, for a robot whose spec gives
    none: IK from the middle of the limits, from zero, then from seeded random postures; the
    first that converges (a spec file should give one: ``seed:``)."""
    chain = spec.chain()
    target = np.array([*spec.sheet_center, TABLE_TOP_Z + READY_HEIGHT])
    rng = np.random.default_rng(0)
    lo, hi = spec.ik_limits(0.02)
    starts = [(lo + hi) / 2, np.clip(np.zeros(chain.dof), lo, hi)] + [rng.uniform(lo, hi) for _ in range(tries)]
    for q0 in starts:
        result = ik.solve(chain, target, q0, lower=lo, upper=hi)
        if result.converged:
            return tuple(float(v) for v in result.q)
    raise InputError(f"robot {spec.name!r} cannot hold its pen vertical 0.10 m above the sheet's centre "
                     f"{tuple(round(float(v), 3) for v in target)} from its base at {spec.base_position}",
                     file=spec.source or None, hint="give a seed posture (seed: [...]) or a base "
                                                    "(--set robot.base=X,Y,Z) in a spec file")


def bare_spec(urdf: Path, overrides: dict) -> RobotSpec:
    """A spec for a bare URDF, with the stated defaults: the URDF's root as the base link, the
    flange ``--set robot.tip`` (else :func:`find_tip`), a 0.10 m pen along the flange's +z, the
    base on a pedestal 2 cm below the table top, behind the sheet at half its reach radius
    (0.30-0.60 m), a seed posture found by IK (:func:`find_seed`) that is also its rest, every
    joint weighted 1 within its URDF limits, efforts and velocities from the URDF, and a stereo
    rig on a stand across the table (:mod:`.rig`)."""
    return spec_from_mapping({"urdf": str(urdf)}, base=Path.cwd(), source=str(urdf), overrides=overrides)


def load_spec(path: Path, overrides: dict) -> RobotSpec:
    """A spec file (YAML, :data:`SPEC_KEYS`)."""
    data = load_yaml(path, "robot spec", unique_keys=True)
    return spec_from_mapping(data, base=Path(path).resolve().parent, source=str(path), overrides=overrides)


def robot_settings(settings: dict[str, str]) -> dict[str, str]:
    """The ``robot.KEY`` pairs of ``--set`` as ``{KEY: VALUE}``; an unknown key is an InputError."""
    out = {}
    for key, value in settings.items():
        if not key.startswith("robot."):
            continue
        name = key[len("robot."):]
        if name not in OVERRIDES:
            # lazy: only this branch needs it
            from ..core.errors import did_you_mean

            raise InputError(f"unknown setting --set {key}; the robot's settings: "
                             + ", ".join(f"robot.{k}" for k in OVERRIDES), hint=did_you_mean(name, list(OVERRIDES)))
        out[name] = value
    return out


def robot_pairs(pairs: list[str] | None, command: str) -> dict[str, str]:
    """The ``--set robot.KEY=VALUE`` pairs of a command that takes the robot's settings only
    (``hila learn``, ``hila robot-sim``) as ``{"robot.KEY": VALUE}``; any other key is an InputError."""
    settings = parse_pairs(pairs)
    stray = [k for k in settings if not k.startswith("robot.")]
    if stray:
        raise InputError(f"{command} --set takes the robot's settings only (robot.KEY=VALUE), got {stray[0]!r}")
    return settings


def resolve(robot: str | None = None, settings: dict[str, str] | None = None) -> RobotSpec:
    """The robot ``--robot NAME|PATH`` names (None: :data:`DEFAULT_ROBOT`), with the
    ``--set robot.KEY=VALUE`` of ``settings``: a registered name, a ``.yaml`` spec file or a
    bare ``.urdf``.  Anything else is an InputError naming the known robots."""
    overrides = robot_settings(settings or {})
    if robot is not None and not str(robot).strip():  # --robot "$UNSET": not silently the iCub
        raise InputError("--robot needs a robot's name or the path of a spec file or URDF, got an empty value")
    name = robot or DEFAULT_ROBOT

    if name in registry.names("robot"):
        spec = registry.robot(name).spec()
        if overrides:
            if spec.generator is not None and overrides.keys() & {"tip", "packages", "pen"}:
                raise InputError(f"robot {name!r} is fixed: --set robot.{sorted(overrides)[0]} cannot change it",
                                 hint="--set robot.KEY applies to a robot made from a URDF (panda, kuka, a file)")
            spec = _apply_overrides(spec, overrides)
            if "tip" in overrides or "pen" in overrides:
                spec = replace(spec, seed=find_seed(spec), rest=None)
                spec = replace(spec, rest=spec.seed)
        return spec
    path = Path(name).expanduser()
    if path.suffix.lower() == ".urdf":
        if not path.is_file():
            raise InputError(f"--robot {name}: no such URDF file")
        return bare_spec(path, overrides)
    if path.suffix.lower() in (".yaml", ".yml"):
        if not path.is_file():
            raise InputError(f"--robot {name}: no such spec file")
        return load_spec(path, overrides)

    raise InputError(f"unknown robot {name!r}; known: {', '.join(registry.names('robot'))}, or a path to a "
                     "spec file (.yaml) or a URDF (.urdf)", hint=did_you_mean(name, registry.names("robot")))


@lru_cache(maxsize=None)
def shipped(name: str) -> RobotSpec:
    """A spec file shipped in ``hila_lang/robot/robots/NAME.yaml`` (panda, kuka)."""
    return load_spec(Path(__file__).parent / "robots" / f"{name}.yaml", {})


def panda() -> RobotSpec:
    """The Franka Emika Panda (``robots/panda.yaml``)."""
    return shipped("panda")


def kuka() -> RobotSpec:
    """The KUKA LBR iiwa (``robots/kuka.yaml``)."""
    return shipped("kuka")
