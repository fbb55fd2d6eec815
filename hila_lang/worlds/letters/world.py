"""The ``letters`` world: a word to write, its letters' slots on the paper, and the paper's image.

Its scene points (``paper.slotK.tl|tr|br|bl``: the K-th letter's box; ``paper.home``) and
questions (``done``, ``next_slot``: a point group such as ``"paper.slot2"``, so ``run
H(s.*)`` binds the template's box corners ``tl tr br bl`` to the slot's; ``next_letter``,
``word``) are declared once in :data:`hila_lang.worlds.letters.WORLD` (``hila show world
letters``); :meth:`LettersWorld.query` answers through that table.  It has no events.

The world follows the program: each state that runs with the pen down writes the next letter
(``notify("state_done", pen_down=True, ...)``); a template for another letter in that slot is a
run error, and so is asking for the same letter three times without writing it (a program
without a branch for that letter would otherwise loop for ever).

At the end it prints the word and writes ``--out`` (default ``runs/write-<UTC time>``):
``paper.png``, the sheet straight from above -- the ink texture of a back end that has one
(PyBullet), else the pen-down trace that touched the paper rasterised the same way -- and
``report.json`` (the word, each letter's slot corners and template, how many points touched).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ...core.errors import HilaRuntimeError, UnknownNameError
from ...core.fileio import OutputFolder
from ...plugins.snapshots import AttributeSnapshots
from ...sim.canvas import Canvas
from ...sim.surface import CONTACT_TOLERANCE, Scene
from . import WORLD
from .layout import layout, PAPER

#: how often a program may ask for a letter without writing it
MAX_ASKS = 3
#: every file the world writes
FILES = ("paper.png", "report.json")


class LettersWorld:
    """Writing ``settings["word"]`` (see the module docstring)."""

    def __init__(self, options, settings: dict[str, Any]) -> None:
        self.options = options
        self.word = settings["word"]
        self.write_report = settings["report"]
        self.layout = layout(self.word, settings["size"])
        #: the output folder, made and proved writable now, before anything is written on the paper
        self.outputs = OutputFolder(options.out, "write-{time}", owned=FILES) if self.write_report else None
        self.scene = Scene(surface=PAPER, home=self.layout.home)
        self.written: list[dict[str, Any]] = []
        self.backend = None
        self._asks = 0
        self.snapshots = AttributeSnapshots(self, ("_asks",), append_only=("written",))

    # -- plug-in hooks -----------------------------------------------------------------------
    def attach(self, backend) -> None:
        self.backend = backend
        backend.reset_hand(self.layout.home)

    def points(self) -> dict[str, np.ndarray]:
        return self.layout.points()

    def _next(self) -> int:
        k = len(self.written)
        if k >= len(self.layout.slots):
            raise HilaRuntimeError(f"every letter of {self.word!r} is written: there is no next letter",
                                   hint="loop with 'until ask done'")
        return k

    def query(self, name: str, *args: Any) -> Any:
        return WORLD.questions.answer(self, name, args, "the letters world")

    # the questions, as declared in :data:`hila_lang.worlds.letters.WORLD` (name, arguments, doc)
    def ask_done(self) -> bool:
        return len(self.written) == len(self.layout.slots)

    def ask_word(self) -> str:
        return self.word

    def ask_next_slot(self) -> str:
        return f"paper.slot{self._next() + 1}"

    def ask_next_letter(self) -> str:
        k = self._next()
        self._asks += 1
        letter = self.layout.slots[k]["letter"]
        if self._asks > MAX_ASKS:
            raise HilaRuntimeError(f"letter {k + 1} ({letter!r}) was asked for {MAX_ASKS} times and never written",
                                   hint=f"does the program run a template for {letter!r}?")
        return letter

    def wait(self, event: str, *args: Any) -> Any:
        raise UnknownNameError("event", event, (), owner="the letters world",
                               hint="the letters world has no events; ask it instead")

    def notify(self, event: str, **data: Any) -> None:
        if event != "state_done" or not data.get("pen_down"):
            return
        k = self._next()
        slot = self.layout.slots[k]
        template = data.get("template")
        name = None if template is None else template.name.split(".")[0]
        if name is not None and name != slot["letter"]:
            raise HilaRuntimeError(f"the template {name!r} wrote in the box of letter {k + 1} ({slot['letter']!r})",
                                   state=data.get("state"))
        executed = data.get("executed")
        drawn = np.asarray(data["path"] if executed is None else executed, dtype=float)
        touching = PAPER.touching(drawn)
        self.written.append({"letter": slot["letter"], "slot": k + 1, "state": data.get("state"),
                             "template": name, "drawn": drawn, "contact_points": int(touching.sum())})
        self._asks = 0

    # -- the end -----------------------------------------------------------------------------
    def paper_image(self) -> np.ndarray:
        """The sheet from above (H, W, 3) uint8 RGB, row 0 its far edge (the letters' tops)."""
        if self.backend is not None and self.backend.ink is not None:
            return self.backend.ink.ink_image()

        canvas = Canvas(PAPER)
        for w in self.written:
            canvas.ink_touching(w["drawn"], PAPER.z, CONTACT_TOLERANCE)
        return canvas.image.copy()

    def finish(self, trace=None, *, fsm=None) -> dict[str, Any]:
        """Print what was written; write ``paper.png`` and ``report.json`` (unless report=no)."""
        where = [i for i, c in enumerate(self.word) if c != " "]
        text = self.word[: where[len(self.written) - 1] + 1] if self.written else ""
        report = {
            "world": "letters", "word": self.word, "written": text,
            "complete": len(self.written) == len(self.layout.slots),
            "letter_height_m": self.layout.height,
            "paper": {"center": list(PAPER.center), "rotation": PAPER.rotation, "z": PAPER.z, "size": list(PAPER.size)},
            "letters": [{"letter": w["letter"], "slot": w["slot"], "state": w["state"], "template": w["template"],
                         "contact_points": w["contact_points"],
                         "corners": {n: [round(float(v), 6) for v in p]
                                     for n, p in self.layout.slots[w["slot"] - 1]["corners"].items()}}
                        for w in self.written],
            "backend": None if self.backend is None else self.backend.name,
        }
        print(f"wrote {text!r}" + ("" if report["complete"] else f" of {self.word!r}"), file=self.options.stdout)
        if self.outputs is not None:
            self.outputs.write_png("paper.png", self.paper_image())
            self.outputs.write_text("report.json", json.dumps(report, indent=2) + "\n")
            self.outputs.close()
            report["out"] = str(self.outputs.path)
            print(f"outputs written to {self.outputs.path}", file=self.options.stdout)
        return report


def make_world(options, settings) -> LettersWorld:
    """Plug-in factory (:data:`hila_lang.worlds.letters.WORLD`)."""
    return LettersWorld(options, settings)
