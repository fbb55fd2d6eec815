"""What a world shows in ``hila studio``, declared on its :class:`~.registry.WorldInfo` (``studio=``).

The studio names no world: every world-specific thing on its pages comes from here, as
``recorder=`` gives ``hila learn --from-sim`` a world's demonstration.

- A **drawing scene** (:class:`DrawingScene`): a picture a person draws a demonstration on, the
  plane it shows (a homography from the plane's (x, y), metres, to the picture's pixels, and the
  plane's height for a 3-D path) and the named points an ICP snaps to.  ``StudioView.scene``
  names the callable that makes it; it is called when a person picks the scene (it may start a
  simulator to render it).
- A **board** (:class:`Board`): the running world's state as a grid of buttons, each labelled,
  and, when a person may choose it, the line the world reads for it from its ``stdin`` (a
  person's move), and a note where a cell needs one (the robot read it otherwise).
  ``StudioView.board`` names ``callable(world) -> Board``.
- The **outcome** of a finished run in words (who won, from the world's own result):
  ``StudioView.outcome`` names ``callable(world) -> str``.
- The **settings** the Run page offers for the world (``StudioView.settings``: setting name ->
  {value: label}), e.g. who plays the opponent.
- A **picture hook** (``StudioView.picture_hook``): a route a person drew on their own uploaded
  picture (a 2-D template in the picture's plane, x right and y up from its bottom-left corner,
  :data:`hila_lang.studio.demonstrate.SHEET_M_PER_PX` metres a pixel) made a scene of the world:
  ``callable(picture, route, template) -> program text`` writes the world's template for it to
  ``template`` and returns a program that runs it; the run names the picture with the world's
  setting ``StudioView.picture_setting`` (the picture world's ``picture.image``), which the Run
  page offers with the pictures of the studio's folder.

Declaring a view imports nothing heavy: the callables are ``"module:callable"`` strings, loaded
when the studio needs them (:meth:`StudioView.load`).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any, Mapping


@dataclass(frozen=True)
class DrawingScene:
    """A picture to draw a demonstration on.

    Attributes
    ----------
    png : bytes
        The picture, PNG.
    width, height : int
        Its size, pixels.
    H : array_like (3, 3)
        Homogeneous map from a plane point (x, y, 1) -- world frame, metres -- to pixels (u right,
        v down); the page inverts it for a click.
    z : float or None
        The plane's height (world frame, metres): a drawing on it is a 3-D path; None for a 2-D one.
    features : tuple of (name, point)
        Named points of the plane an ICP snaps to, each (x, y) or (x, y, z), metres.
    lift : float or None
        With ``z``: the highest the pen rises above the plane between strokes, metres (a pen-up
        move rises and comes down at 45 degrees, no higher than this).
    """

    png: bytes
    width: int
    height: int
    H: Any
    z: float | None = None
    features: tuple = ()
    lift: float | None = None


@dataclass(frozen=True)
class Board:
    """A world's state as a grid of buttons, row by row, ``columns`` wide.

    ``labels[i]`` is what button i shows; ``answers[i]`` the line the world reads for it when a
    person chooses it (its ``stdin``), or None when it is not a choice now; ``notes[i]`` (when
    given) a line the page shows on the cell and marks it by, e.g. that the robot read it
    otherwise, or None.
    """

    columns: int
    labels: tuple[str, ...]
    answers: tuple[str | None, ...]
    notes: tuple[str | None, ...] = ()

    def to_json(self) -> dict:
        notes = self.notes or (None,) * len(self.labels)
        return {"columns": self.columns,
                "cells": [{"label": label, "answer": answer, "note": note}
                          for label, answer, note in zip(self.labels, self.answers, notes)]}


@dataclass(frozen=True)
class StudioView:
    """A world's part in the studio.

    Attributes
    ----------
    scene : str or None
        ``"module:callable"``: ``callable() -> DrawingScene``, what the Demonstrate page offers
        to draw on for this world; None: none.
    scene_label : str
        The scene's name in the page's menu.
    board : str or None
        ``"module:callable"``: ``callable(world) -> Board or None``, drawn on the Run page after
        every step; None: no board.
    outcome : str or None
        ``"module:callable"``: ``callable(world) -> str``, what the Run page says when the
        program has finished (who won: the world's result, in words); None: "finished".
    settings : mapping setting name -> {value: label}
        The world's settings the Run page offers, each value with the words the menu shows
        (the first value is the menu's default).
    hint : str
        One line the Run page shows under its buttons for a program in this world.
    picture_hook : str or None
        ``"module:callable"``: ``callable(picture: Path, route: Path, template: Path) -> str``, the
        picture hook (module docstring); an :class:`~hila_lang.core.errors.InputError` for a route
        that does not fit the world.  None: the world takes no person's picture.
    picture_setting : str
        The world's setting that names the picture a run prints on its scene (with ``picture_hook``).
    """

    scene: str | None = None
    scene_label: str = ""
    board: str | None = None
    outcome: str | None = None
    settings: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    hint: str = ""
    picture_hook: str | None = None
    picture_setting: str = ""

    def load(self, attr: str):
        """The callable ``attr`` (``"scene"``, ``"board"``, ``"outcome"`` or ``"picture_hook"``) names, imported now."""
        module, _, name = getattr(self, attr).partition(":")
        return getattr(importlib.import_module(module), name)
