"""The two small interfaces the language core runs against: a back end and a world.

The interpreter knows nothing about PyBullet or tic-tac-toe.  A *back end* moves the hand; a
*world* names scene points and answers questions.  ``hila_lang.language`` ships a dry back end
and a scripted test world; ``hila_lang.robot`` and ``hila_lang.games`` plug in behind the same
interfaces.

Units and frames: every point is a numpy array of shape (D,) with D = 3, in metres, in the world
frame of the scene (z up).  Paths are arrays of shape (T, 3).
"""

from __future__ import annotations

from typing import Any, Mapping, Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Backend(Protocol):
    """Executes Cartesian paths and reports where the hand (pen tip) is."""

    name: str

    def hand_position(self) -> np.ndarray:
        """Current pen-tip position, shape (3,), metres, world frame."""
        ...

    def move(self, path: np.ndarray, *, pen_down: bool = False, label: str = "") -> np.ndarray:
        """Follow ``path`` (T, 3) and return the pen-tip trace actually executed (T', 3).

        ``pen_down`` says the segment is meant to touch the paper (drawing): ink is laid only
        where the pen is down and the tip touches the surface.  ``label`` names the FSM state,
        for traces and error messages.  Raises :class:`~hila_lang.errors.UnreachableError`
        when a waypoint cannot be reached.
        """
        ...

    def close(self) -> None:
        """Release resources (a PyBullet client, windows)."""
        ...


@runtime_checkable
class World(Protocol):
    """Named scene objects with ICPs, events and predicates."""

    #: the ``--set KEY=VALUE`` keys this world understands (``osila.*`` keys go to OSILA); any
    #: other key is refused before the run, so a typo is not silently ignored
    SETTINGS: tuple[str, ...]

    def points(self) -> Mapping[str, np.ndarray]:
        """Every named scene point known now, e.g. ``{"board.cell5.tl": array([x, y, z]), ...}``."""
        ...

    def query(self, name: str, *args: Any) -> Any:
        """Answer a named question or predicate (``"game_over"``, ``"best_move"``, ...).

        Unknown names raise ``KeyError``; the interpreter turns that into a runtime error that
        names the state and program line.
        """
        ...

    def wait(self, event: str, *args: Any) -> Any:
        """Block until ``event`` happens (``"opponent_moved"``) and return its value."""
        ...

    def notify(self, event: str, **data: Any) -> None:
        """Tell the world what the robot did (``"state_done"`` with the state and its path)."""
        ...
