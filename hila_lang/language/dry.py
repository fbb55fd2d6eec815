"""The dry back end: kinematic, no physics — the hand follows every path exactly.

Where the hand starts: the world's ``home`` attribute (a point) if it has one, else
``--set hand=X,Y,Z``, else the origin; a program's ``hand at POINT`` then moves it there with
:meth:`DryBackend.reset_hand` before the first state.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..validation import check_path


class DryBackend:
    """Implements :class:`hila_lang.interfaces.Backend`; records every move in :attr:`moves`."""

    name = "dry"

    def __init__(self, start=(0.0, 0.0, 0.0)) -> None:
        self._hand = np.asarray(start, dtype=float).reshape(3).copy()
        self.moves: list[tuple[str, np.ndarray, bool]] = []

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
        self.moves.append((label, arr.copy(), bool(pen_down)))
        self._hand = arr[-1].copy()
        return arr.copy()

    def close(self) -> None:
        pass


def _parse_point(text: str) -> np.ndarray:
    try:
        values = [float(v) for v in text.replace("(", "").replace(")", "").split(",")]
    except ValueError:
        values = []
    if len(values) != 3:
        raise InputError(f"expected --set hand=X,Y,Z (three numbers, metres), got {text!r}")
    return np.array(values)


def make_backend(world, options) -> DryBackend:
    """Plug-in factory (see :mod:`hila_lang.language.plugins`)."""
    home = getattr(world, "home", None)
    if home is None and options is not None and "hand" in options.settings:
        home = _parse_point(options.settings["hand"])
    return DryBackend(home if home is not None else (0.0, 0.0, 0.0))
