"""The map moving while the robot draws, and the robot following it: the picture world's ``tracking``.

``--set map.slide=D``, ``map.turn=DEG``, ``map.jump=D`` move the task sheet during the robot's
pen-down strokes (:class:`hila_lang.sim.motion.SheetMotion`: the referee's side; the bent
sheet's mesh is moved rigidly in the table's plane at every control step).  A program that
tracks its match (``run route(m.*) track m``) makes the robot look again at each tick
(:meth:`PictureTracking.look`): both eyes, its features matched against the demonstration's and
verified as ``ask matched`` does, its arm left where it is (its own body masked in the images,
as always).  With the arm over the map it finds only some of them, each a few millimetres off, so
it does not take their places as they come: it fits how the map moved in the table's plane (a
turn and a shift) to the features it found again, by the pair of them that most others agree
with (within :data:`AGREE`; every pair is tried, so it is deterministic), refits on those that
agree, and moves every feature it knew by that; with fewer than :data:`MIN_AGREE` agreeing it
keeps what it knew.  (Taking the matched points as they came, four of fifteen features a few mm
off turned the route 5-15 cm off the map: unreachable.)  The route is scored where its ink lies
on the sheet in its final position.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ...osila.fallback import fit_similarity
from ...sim.motion import carried, moved, SheetMotion

#: a feature found again agrees with a move of the map when the move puts it this near, metres
AGREE = 0.003
#: ... and a look counts when at least this many agree
MIN_AGREE = 3


def pose_of(sheet) -> tuple:
    """A sheet's pose (x, y, rotation) as :mod:`hila_lang.sim.motion` moves it."""
    return (float(sheet.center[0]), float(sheet.center[1]), float(sheet.rotation))


def body_pose(start: tuple, now: tuple) -> np.ndarray:
    """The (4, 4) pose of a mesh built in world coordinates at pose ``start`` that moved to ``now``."""
    a = now[2] - start[2]
    c, s = math.cos(a), math.sin(a)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:2, 3] = np.asarray(now[:2]) - T[:2, :2] @ np.asarray(start[:2])
    return T


class PictureTracking:
    """The ``tracking`` capability of :class:`~.world.PictureWorld` (see the module docstring)."""

    def __init__(self, world, settings: dict) -> None:
        self.world = world
        self.settings = settings
        self.motion: SheetMotion | None = None
        self.start = None  # the task sheet's pose when its mesh was built

    def lay(self, sheet) -> None:
        """The task sheet is laid out (its mesh built at ``sheet``'s pose): its moves start from there."""
        self.start = pose_of(sheet)
        self.motion = SheetMotion(self.start, np.random.default_rng([self.world.seed, 34]),
                                  slide=self.settings["map.slide"], turn=self.settings["map.turn"],
                                  jump=self.settings["map.jump"])

    @property
    def moving(self) -> bool:
        return self.motion is not None and self.motion.active

    def begin(self, state: str, pen_down: bool, seconds: float) -> None:
        if pen_down and self.motion is not None:
            self.motion.begin(pose_of(self.world.task), seconds)

    def elapse(self, t: float) -> None:
        pose = None if self.motion is None else self.motion.pose(t)
        if pose is None:
            return

        world = self.world
        world.task = replace(world.task, center=(pose[0], pose[1]), rotation=pose[2])
        world.backend.sim.set_pose(world.sheet_body, body_pose(self.start, pose))

    def look(self) -> None:
        world = self.world
        known = dict(world.points_now)
        world._match(move_arm=False)
        world.points_now = followed(known, world.points_now)

    def end(self) -> None:
        if self.motion is not None:
            self.motion.end()

    def carried(self, executed: np.ndarray) -> np.ndarray:
        """The pen samples of the stroke just drawn, where they lie on the sheet now."""
        during = [] if self.motion is None else self.motion.during
        return carried(executed, during, pose_of(self.world.task)) if during else executed


def followed(known: dict, found: dict) -> dict:
    """Every point of ``known`` (name -> (3,) or None) moved as the map moved to the points
    ``found`` again (see the module docstring); ``known`` itself when too few agree."""
    common = [n for n, p in known.items() if p is not None and found.get(n) is not None]
    if len(common) < MIN_AGREE:
        return known
    a = np.array([known[n][:2] for n in common])
    b = np.array([found[n][:2] for n in common])

    def rigid(i, j):  # the turn and shift taking a[i], a[j] to b[i], b[j]
        turn = math.atan2(*(b[j] - b[i])[::-1]) - math.atan2(*(a[j] - a[i])[::-1])
        c, s = math.cos(turn), math.sin(turn)
        R = np.array([[c, -s], [s, c]])
        return R, b[i] - R @ a[i]

    best = None
    for i in range(len(common)):
        for j in range(i + 1, len(common)):
            if np.linalg.norm(a[j] - a[i]) < 4 * AGREE:
                continue
            R, t = rigid(i, j)
            agree = np.linalg.norm(a @ R.T + t - b, axis=1) < AGREE
            if best is None or agree.sum() > best.sum():
                best = agree
    if best is None or best.sum() < MIN_AGREE:
        return known
    scale, R, t = fit_similarity(a[best], b[best], 2)
    out = {}
    for n, p in known.items():
        if p is None:
            out[n] = None
            continue
        q = np.array(p, dtype=float)
        q[:2] = scale * R @ q[:2] + t
        out[n] = q
    return out


__all__ = ["PictureTracking", "body_pose", "followed", "moved", "pose_of"]
