"""Where the robot writes: an A4 sheet on its table and a box (a *slot*) per letter.

The sheet lies landscape in front of the robot, centred at (0.30, -0.09) (every point of it within
the arm's reach: docs/design.md §5).  The word is written on one line across it, upright for the robot (a
letter's top is away from it) and read from the robot's left to its right, centred on the sheet.
Each letter's box has the demonstrations' proportions (:data:`.handwriting.BOX`, width = 0.8 x
height); a space is an empty box; boxes are :data:`GAP` letter heights apart.  A slot's corners
are named as in the demonstrations: ``tl`` (top-left, far-left as the robot sees it), ``tr``,
``br``, ``bl``; they are the scene points ``paper.slotK.tl`` ... for the K-th letter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.errors import InputError
from ...robot.workspace import PAPER_THICKNESS, TABLE_TOP_Z
from ...sim.surface import Surface
from .handwriting import BOX

#: the robot's sheet: A4 landscape (across 0.297 m, depth 0.210 m) on its table
PAPER = Surface(center=(0.30, -0.09), rotation=0.0, z=TABLE_TOP_Z + PAPER_THICKNESS, size=(0.297, 0.210))
#: letter box width / height (the demonstrations' box)
ASPECT = BOX[0] / BOX[1]
#: space between letter boxes, in letter heights
GAP = 0.2
#: margin kept free along the sheet's left and right edges, metres
MARGIN = 0.02
#: where the hand waits: this high above the sheet's centre, metres
HOME_HEIGHT = 0.08


@dataclass(frozen=True)
class Layout:
    """The word's letters on the sheet.

    Attributes
    ----------
    word : str
    height : float
        Letter height, metres.
    slots : list of dict
        One per letter (spaces have none): ``{"letter": "H", "corners": {"tl": (3,), ...}}``.
    paper : Surface
    """

    word: str
    height: float
    slots: list
    paper: Surface

    @property
    def home(self) -> np.ndarray:
        return self.paper.to_world(0.0, 0.0) + np.array([0.0, 0.0, HOME_HEIGHT])

    def points(self) -> dict[str, np.ndarray]:
        """``paper.slotK.tl|tr|br|bl`` (K from 1) and ``paper.home``."""
        pts = {"paper.home": self.home}
        for k, slot in enumerate(self.slots, start=1):
            for name, p in slot["corners"].items():
                pts[f"paper.slot{k}.{name}"] = p.copy()
        return pts


def layout(word: str, height: float, paper: Surface = PAPER) -> Layout:
    """Place ``word`` (capitals and spaces) at letter ``height`` metres on ``paper``.

    Raises :class:`InputError` when the word does not fit on one line, saying what would.
    """
    width, gap = ASPECT * height, GAP * height
    n = len(word)
    needed = n * width + (n - 1) * gap
    room = paper.size[0] - 2 * MARGIN
    if needed > room:
        fits = int((room + gap) // (width + gap))
        smaller = room / (n * ASPECT + (n - 1) * GAP)
        raise InputError(f"the word {word!r} needs {needed:.3f} m of the sheet's {room:.3f} m at size={height:g}: "
                         f"{fits} characters fit", hint=f"shorten it, or set size={smaller:.3f} or less")
    slots = []
    for i, letter in enumerate(word):
        if letter == " ":
            continue
        left = -needed / 2 + i * (width + gap)
        r = np.array([left, left + width, left + width, left])
        f = np.array([height / 2, height / 2, -height / 2, -height / 2])
        corners = dict(zip(("tl", "tr", "br", "bl"), paper.to_world(r, f)))
        slots.append({"letter": letter, "corners": corners})
    return Layout(word, float(height), slots, paper)
