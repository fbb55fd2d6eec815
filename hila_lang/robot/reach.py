"""The arm's reach without a simulator: a kinematic bound, the checks every back end makes of a
planned path, and an unreachable move told in the program's terms.

Every robot's bound is computed from its chain the same way
(:meth:`hila_lang.robot.spec.RobotSpec.reach`, :func:`hila_lang.robot.spec.chain_reach`); the
iCub's, below, is also declared as numbers so that declaring the back ends imports nothing.

**The bound.**  Whatever its joint angles, the pen tip of the iCub's torso + right-arm chain (the
chain :mod:`hila_lang.robot.arm` solves, pen included) is never farther from the torso pitch
joint's origin :data:`REACH_CENTRE` than the sum of the chain's link lengths (triangle
inequality): :data:`REACH_RADIUS`.  Measured on the generated iCub URDF (icub-models 3.2.0,
``tests/test_reach.py`` recomputes both from the URDF and fails if the model changes): link
lengths 0.071, 0.080, 0.152, 0.016, 0.026, 0.139, 0.045, 0.107, 0.020 m and the pen tip 0.121 m
beyond the last joint, 0.776 m in all.  The bound is sound (no point outside it can be reached)
but loose: over 20,000 seeded random postures within the URDF limits the farthest pen tip was
0.650 m from the centre, and the pen must also stay vertical, so a point inside may still be out
of reach -- the run then says so (PyBullet's IK), naming the target.

:func:`check_planned` is what a back end checks of a planned path before it moves (the dry
back end and PyBullet's arm share it): every waypoint within the bound, none below the paper on
the table.  ``hila check`` (:mod:`hila_lang.language.worldcheck`) refuses a bound target outside
the bound for a back end that declares it (``BackendInfo.reach``).
"""

from __future__ import annotations

import numpy as np

from ..core.errors import UnreachableError
from .workspace import TABLE_FRONT_X, TABLE_SIZE

from . import REACH

#: the torso pitch joint's origin, world frame, metres (the root at (0, 0, 0.62), facing +x)
#: and the sum of the arm chain's link lengths from that origin to the pen tip, metres
REACH_CENTRE, REACH_RADIUS = REACH
#: how far below the paper a target on the table may be before it is refused, metres
BELOW_PAPER = 0.002


def _fmt(p) -> str:
    return "(" + ", ".join(f"{float(v):.3f}" for v in p) + ")"


def beyond(point, centre=REACH_CENTRE, radius: float = REACH_RADIUS) -> float:
    """How far ``point`` (3,) lies outside the reach ball, metres (<= 0: inside)."""
    return float(np.linalg.norm(np.asarray(point, dtype=float) - np.asarray(centre, dtype=float)) - radius)


def out_of_reach(point, centre=REACH_CENTRE, radius: float = REACH_RADIUS) -> str | None:
    """Why ``point`` cannot be reached (the distances), or None when the bound allows it."""
    off = beyond(point, centre, radius)
    if off <= 0:
        return None
    return (f"it is {off + radius:.3f} m from the arm's base {_fmt(centre)}, {off:.3f} m beyond the farthest "
            f"the pen can be ({radius:.3f} m)")


def check_planned(path, surface_z: float | None, label: str = "", reach=REACH) -> None:
    """Refuse a planned path (T, 3) that leaves the reach bound ``reach`` (``((x, y, z), radius)``,
    the robot's: :meth:`~hila_lang.robot.spec.RobotSpec.reach`; default the iCub's) or goes
    below the paper (``surface_z``; None: no paper) over the table: :class:`UnreachableError`
    (see :func:`unreachable`)."""
    path = np.asarray(path, dtype=float)
    centre, radius = reach
    off = np.linalg.norm(path - np.asarray(centre), axis=1) - radius
    k = int(np.argmax(off))
    if off[k] > 0:
        raise unreachable(path[k], out_of_reach(path[k], centre, radius), float(off[k]), label)
    if surface_z is None:
        return
    on_table = (path[:, 0] >= TABLE_FRONT_X) & (path[:, 0] <= TABLE_FRONT_X + TABLE_SIZE[0])
    below = np.where(on_table, surface_z - path[:, 2], -np.inf)
    k = int(np.argmax(below))
    if below[k] > BELOW_PAPER:
        raise unreachable(path[k], f"it is {below[k] * 1000:.1f} mm below the paper", float(below[k]), label)


def unreachable(point, reason: str, distance: float, label: str = "", where: str = "") -> UnreachableError:
    """``cannot reach POINT m[ where]: REASON; the arm did not move``, an :class:`UnreachableError`
    that keeps the point (``exc.point``), the reason and how far off the pen stays (``exc.distance``,
    metres), so :func:`name_the_target` can retell it."""
    exc = UnreachableError(f"cannot reach {_fmt(point)} m{where}: {reason}; the arm did not move",
                           state=label or None, hint=HINT)
    exc.point, exc.reason, exc.distance = np.asarray(point, dtype=float).copy(), reason, float(distance)
    return exc


HINT = "targets must be above the table, in front of the robot (x 0.20-0.45 m, y -0.30-0.10 m works at table height)"


def name_the_target(exc: UnreachableError, icps: dict, ref: str) -> UnreachableError:
    """``exc`` told in the program's terms: the ICP of ``ref`` (the run's template) that the
    unreachable point is, or is on the way to, with its bound value, and why (how far off).
    An error that kept no point (:func:`unreachable`) is returned as it is."""
    point = getattr(exc, "point", None)
    if point is None or not icps:
        return exc
    names = [k for k in icps if k not in ("start", "end")] or list(icps)
    name = min(names, key=lambda k: np.linalg.norm(np.asarray(icps[k], float) - point))
    target = np.asarray(icps[name], dtype=float)
    gap = float(np.linalg.norm(target - point))
    what = (f"the target {name} = {_fmt(target)} of '{ref}'" if gap < 0.01 else
            f"{_fmt(point)} on the way to the target {name} = {_fmt(target)} of '{ref}' ({gap:.3f} m from it)")
    new = UnreachableError(f"cannot reach {what}: {exc.reason}; the arm did not move", state=exc.state, hint=exc.hint)
    new.point, new.reason, new.distance = point, exc.reason, exc.distance
    return new
