"""A sheet that moves while the robot draws: slides, turns and jumps, seeded (the referee's side).

Worlds' settings (``board.slide=D`` in tic-tac-toe, ``map.slide=D`` in the picture world ...),
applied during every stroke the robot draws with its pen down; the back end's ``streaming``
clock calls :meth:`SheetMotion.pose` at every control step of it:

- ``slide=D``: the sheet slides D metres in a seeded direction over :data:`SLIDE_SECONDS`,
  with a minimum-jerk profile (a push that starts and stops smoothly), starting at a seeded
  20-60 % of the stroke's planned duration;
- ``turn=DEG``: during that slide (or alone) it turns by DEG degrees, seeded sign, about its
  pose's centre;
- ``jump=D``: at a seeded 20-60 % of the stroke it jumps D metres at once (a knock).

Each move keeps the sheet within D (and DEG) of where it was laid out: the direction is drawn
among those that keep it there, the turn's sign is the one that does.  A pose is ``(x, y,
rotation)``: where the sheet's reference point is (metres, world frame) and how it is turned
about +z (radians).  The moves are the truth: the robot sees them only through its eyes.  The
pose at every control step of the stroke is kept (:attr:`SheetMotion.during`), so a referee can
score ink where it lies on the sheet in its final position (:func:`carried`).  Pure numpy.
"""

from __future__ import annotations

import math

import numpy as np

from ..osila.motion import minimum_jerk

#: how long a slide (and turn) takes, seconds (the issue-34 scene: 3 cm and 10 degrees in 1.5 s)
SLIDE_SECONDS = 1.5
#: a move starts at this fraction of the stroke's planned duration (seeded, uniform)
START_FRACTION = (0.2, 0.6)

Pose = tuple  # (x, y, rotation): metres, metres, radians


class SheetMotion:
    """The sheet's moves during the robot's strokes (see the module docstring).

    Parameters
    ----------
    home : (x, y, rotation)
        Where the sheet was laid out (the moves stay near it).
    rng : numpy.random.Generator
        The referee's seeded generator (its own: the other draws stay as they were).
    slide, turn, jump : float
        Metres, degrees, metres (0: none).
    """

    def __init__(self, home: Pose, rng: np.random.Generator, *, slide: float = 0.0, turn: float = 0.0,
                 jump: float = 0.0) -> None:
        self.home = tuple(float(v) for v in home)
        self.rng = rng
        self.slide, self.turn, self.jump = float(slide), float(turn), float(jump)
        self.plan: dict | None = None
        #: the sheet's pose at every control step of the stroke under way (or the last one)
        self.during: list[Pose] = []
        #: one entry per stroke it moved during: what happened (for reports)
        self.moves: list[dict] = []

    @property
    def active(self) -> bool:
        return self.slide > 0 or self.turn > 0 or self.jump > 0

    def _direction(self, offset: np.ndarray, distance: float) -> np.ndarray:
        """A seeded unit direction ``u`` that keeps ``offset + distance * u`` within ``distance`` of
        the layout (uniform among those: drawn again while it would not; straight home after 20)."""
        for _ in range(20):
            angle = self.rng.uniform(0.0, 2.0 * math.pi)
            u = np.array([math.cos(angle), math.sin(angle)])
            if np.linalg.norm(offset + distance * u) <= distance + 1e-12:
                return u
        return -offset / max(float(np.linalg.norm(offset)), 1e-12)

    def begin(self, pose: Pose, seconds: float) -> None:
        """A pen-down stroke of ``seconds`` begins with the sheet at ``pose``: draw its moves."""
        self.during = []
        if not self.active:
            self.plan = None
            return
        offset = np.subtract(pose[:2], self.home[:2])
        turned = pose[2] - self.home[2]
        plan = {"from": tuple(pose), "at": float(self.rng.uniform(*START_FRACTION) * seconds), "shift": np.zeros(2),
                "turn": 0.0, "jump": np.zeros(2)}
        if self.slide > 0:
            plan["shift"] = self.slide * self._direction(offset, self.slide)
        if self.turn > 0:
            sign = 1.0 if self.rng.uniform() < 0.5 else -1.0
            if abs(turned + sign * math.radians(self.turn)) > math.radians(self.turn) + 1e-12:
                sign = -sign
            plan["turn"] = sign * math.radians(self.turn)
        if self.jump > 0:
            plan["jump"] = self.jump * self._direction(offset + plan["shift"], self.jump)
        self.plan = plan
        self.moves.append({"at_s": round(plan["at"], 3), "slide_mm": round(1000 * float(np.linalg.norm(plan["shift"])), 2),
                           "turn_deg": round(math.degrees(plan["turn"]), 2),
                           "jump_mm": round(1000 * float(np.linalg.norm(plan["jump"])), 2)})

    def pose(self, t: float) -> Pose | None:
        """The sheet ``t`` seconds into the stroke (kept in :attr:`during`); None when it does not move."""
        plan = self.plan
        if plan is None:
            return None
        x, y, rotation = plan["from"]
        w = float(minimum_jerk((t - plan["at"]) / SLIDE_SECONDS)) if t >= plan["at"] else 0.0
        jumped = plan["jump"] if t >= plan["at"] else np.zeros(2)
        centre = np.array([x, y]) + w * plan["shift"] + jumped
        pose = (float(centre[0]), float(centre[1]), rotation + w * plan["turn"])
        self.during.append(pose)
        return pose

    def end(self) -> None:
        self.plan = None


def moved(points: np.ndarray, before: Pose, after: Pose) -> np.ndarray:
    """``points`` (..., 3) on a sheet at pose ``before``, where they are with the sheet at ``after``
    (a rigid motion in the table's plane; heights unchanged)."""
    out = np.array(points, dtype=float)
    a = after[2] - before[2]
    c, s = math.cos(a), math.sin(a)
    rel = out[..., :2] - np.asarray(before[:2])
    out[..., 0] = after[0] + c * rel[..., 0] - s * rel[..., 1]
    out[..., 1] = after[1] + s * rel[..., 0] + c * rel[..., 1]
    return out


def carried(executed: np.ndarray, during: list[Pose], final: Pose) -> np.ndarray:
    """The pen samples ``executed`` (N, 3), each taken where the sheet was at its step (``during``,
    one pose per sample), put where that place of the sheet is with the sheet at ``final``: the
    ink as it lies on the sheet now.  Samples beyond ``during`` are taken as at ``final``."""
    out = np.array(executed, dtype=float)
    for i, pose in enumerate(during[: len(out)]):
        out[i] = moved(out[i], pose, final)
    return out
