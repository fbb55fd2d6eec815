"""The scripted world's moving points: its ``tracking`` capability (``track`` in tests and examples).

A script's ``motion`` is a list of moves, each a mapping:

- ``points``: a point's name or a group prefix (``board.cell5`` moves ``board.cell5.tl``, ...);
- ``state``: the run state it happens in (its FSM name, e.g. ``main/mark/draw``; ``hila compile``
  lists them) and ``visit``: the how-manieth time that state runs (1-based; default 1);
- ``at``: seconds after that step began moving (default 0);
- ``seconds``: how long the move takes (default 0: a jump); it follows a minimum-jerk profile;
- ``shift``: ``[dx, dy, dz]`` metres (default none);
- ``turn``: degrees about +z around the moved points' centre (default 0).

:class:`ScriptedTracking` moves the points (the truth) as the back end's clock runs
(``elapse``); ``points()`` of the world says where they were at the robot's last ``look``
while a step runs, and where they are between steps.  The scripted world perceives perfectly:
it is the fake world tests drive the engine with.  A move still under way when its step ends
stops there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core.errors import InputError
from ...osila.motion import minimum_jerk

_KEYS = {"points", "state", "visit", "at", "seconds", "shift", "turn"}


@dataclass(frozen=True)
class Move:
    """One scripted move (see the module docstring)."""

    points: str
    state: str
    visit: int = 1
    at: float = 0.0
    seconds: float = 0.0
    shift: tuple = (0.0, 0.0, 0.0)
    turn: float = 0.0

    @classmethod
    def of(cls, value, i: int) -> "Move":
        where = f"motion[{i}]"
        if not isinstance(value, dict):
            raise InputError(f"expected {where} as a mapping with keys {', '.join(sorted(_KEYS))}, got {value!r}")
        unknown = set(value) - _KEYS
        if unknown:
            raise InputError(f"unknown key {sorted(unknown)[0]!r} in {where}; expected {', '.join(sorted(_KEYS))}")
        for key, what in (("points", "a point's name or a group prefix"), ("state", "a run state's name")):
            if not isinstance(value.get(key), str):
                raise InputError(f"expected {where}.{key} as {what}, got {value.get(key)!r}")
        numbers = {}
        for key, low in (("visit", 1), ("at", 0.0), ("seconds", 0.0), ("turn", -360.0)):
            v = value.get(key, cls.__dataclass_fields__[key].default)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < low:
                raise InputError(f"expected {where}.{key} as a number of at least {low:g}, got {v!r}")
            numbers[key] = v
        if not float(numbers["visit"]).is_integer():
            raise InputError(f"expected {where}.visit as a whole number, got {numbers['visit']!r}")
        shift = np.asarray(value.get("shift", (0.0, 0.0, 0.0)), dtype=float).reshape(-1)
        if shift.shape != (3,) or not np.isfinite(shift).all():
            raise InputError(f"expected {where}.shift as [dx, dy, dz] metres, got {value.get('shift')!r}")
        return cls(value["points"], value["state"], int(numbers["visit"]), float(numbers["at"]), float(numbers["seconds"]),
                   tuple(shift), float(numbers["turn"]))

    def done(self, t: float) -> float:
        """How much of the move is done ``t`` seconds after its step began (0..1, minimum jerk)."""
        if t < self.at:
            return 0.0
        if self.seconds <= 0:
            return 1.0
        return float(minimum_jerk((t - self.at) / self.seconds))

    def apply(self, points: dict, names: list, fraction: float) -> None:
        """Move ``names`` of ``points`` (its values as the step began) by ``fraction`` of the move."""
        if not names:
            return
        centre = np.mean([points[n] for n in names], axis=0)
        a = math.radians(self.turn) * fraction
        R = np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
        for n in names:
            points[n] = centre + R @ (points[n] - centre) + fraction * np.asarray(self.shift)


class ScriptedTracking:
    """The ``tracking`` capability of :class:`~.world.ScriptedWorld` (module docstring)."""

    def __init__(self, world, moves) -> None:
        self.world = world
        self.moves = [m if isinstance(m, Move) else Move.of(m, i) for i, m in enumerate(moves or ())]
        self.moving = bool(self.moves)
        self.visits: dict[str, int] = {}  # run state -> times it was streamed
        self._now: tuple[str, int] | None = None  # the step streaming now, and its visit
        self._start: dict | None = None  # the true points when this step began

    def _members(self, move: Move) -> list[str]:
        pts = self.world._true
        return [n for n in pts if n == move.points or n.startswith(move.points + ".")]

    def begin(self, state: str, pen_down: bool, seconds: float) -> None:
        self.visits[state] = self.visits.get(state, 0) + 1
        self._now = (state, self.visits[state])
        self._start = {k: v.copy() for k, v in self.world._true.items()}
        self.world._seen = dict(self._start)

    def elapse(self, t: float) -> None:
        if self._start is None:
            return
        pts = {k: v.copy() for k, v in self._start.items()}
        for move in self.moves:
            if (move.state, move.visit) == self._now:
                move.apply(pts, self._members(move), move.done(t))
        self.world._true = pts

    def look(self) -> None:
        self.world._seen = {k: v.copy() for k, v in self.world._true.items()}

    def end(self) -> None:
        self._start = self._now = None
        self.world._seen = None
