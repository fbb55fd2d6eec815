"""The dry back end: kinematic, no physics — the hand follows every path exactly.

Where the hand starts: the world's ``scene.home`` (a point) if it has one, else
``--set hand=X,Y,Z`` (a setting of this back end), else where PyBullet starts the pen: 0.10 m
above the paper's centre (:func:`hila_lang.robot.workspace.ready_point`); a program's
``hand at POINT`` then moves it there with :meth:`DryBackend.reset_hand` before the first state.
It has no eyes, no ink, no overview camera, no lights and no window (those capabilities are None);
its ``snapshots`` copy where the hand is and cut the list of moves back; its ``streaming``
(:class:`~hila_lang.robot.streaming.DryStream`) follows a path whose tail changes, at the arm's
pen speeds, deterministically (the ``track`` clause).

It checks what PyBullet's arm checks of a planned path before it moves
(:func:`hila_lang.robot.reach.check_planned`): every waypoint within the arm's kinematic reach
bound, none below the paper over the table (the world's surface, else the default sheet, as
PyBullet lays it).  A path that fails is an :class:`~hila_lang.core.errors.UnreachableError` (exit 1),
as on PyBullet: a program that runs dry runs on the robot as far as the kinematics can tell.
"""

from __future__ import annotations

import numpy as np

from ..core.bounded import BoundedLog
from ..core.errors import InputError
from ..core.validation import check_path
from ..plugins.snapshots import AttributeSnapshots
from .reach import check_planned
from .streaming import DryStream
from .workspace import default_surface, ready_point


#: moves kept in :attr:`DryBackend.moves`
KEEP_MOVES = 1000


class DryBackend:
    """Implements :class:`hila_lang.plugins.protocols.Backend`; records every move in :attr:`moves`."""

    name = "dry"
    eyes = None
    ink = None
    overview = None
    view = None
    lighting = None

    def __init__(self, start=(0.0, 0.0, 0.0), surface_z: float | None = None, reach=None) -> None:
        #: the paper's height, metres (None: no paper, no table check)
        self.surface_z = surface_z
        #: the robot's reach bound ((x, y, z), radius) (:meth:`~.spec.RobotSpec.reach`; None: the iCub's)
        self.reach = reach
        self._hand = np.asarray(start, dtype=float).reshape(3).copy()
        #: every move (label, path, pen_down); the newest kept (:class:`~hila_lang.core.bounded.BoundedLog`)
        self.moves: BoundedLog = BoundedLog(KEEP_MOVES)
        self.snapshots = AttributeSnapshots(self, ("_hand",), append_only=("moves",))

        self.streaming = DryStream(self)

    def hand_position(self) -> np.ndarray:
        return self._hand.copy()

    def reset_hand(self, point) -> None:
        """Put the hand at ``point`` (3,) without moving along a path."""
        p = np.asarray(point, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.isfinite(p).all():
            raise InputError(f"expected a hand position of 3 finite numbers, got {p.tolist()}")
        self._hand = p.copy()

    def move(self, path, *, pen_down: bool = False, label: str = "") -> np.ndarray:
        arr = check_path(path, "path")
        if arr.shape[1] != 3:
            raise InputError(f"expected a path of shape (T, 3), got {arr.shape}")

        if self.reach is None:
            check_planned(arr, self.surface_z, label)
        else:
            check_planned(arr, self.surface_z, label, self.reach)
        self.moves.append((label, arr.copy(), bool(pen_down)))
        self._hand = arr[-1].copy()
        return arr.copy()

    def close(self) -> None:
        pass


def make_backend(scene, options, settings) -> DryBackend:
    """Plug-in factory (see :mod:`hila_lang.plugins.registry`); the robot's reach and sheet come
    from ``options.robot`` (a :class:`~.spec.RobotSpec`; None: the iCub's)."""
    robot = getattr(options, "robot", None)
    home = None if scene is None else scene.home
    if home is None:
        home = settings.get("hand")
    surface = scene.surface if scene is not None and scene.surface is not None else \
        (robot.default_surface() if robot is not None else default_surface())
    return DryBackend(home if home is not None else ready_point(surface), surface_z=surface.z,
                      reach=None if robot is None else robot.reach())
