"""Letters: the iCub writes a short word on paper, one learned template per letter.

Each capital letter was demonstrated ONCE by a seeded human-like handwriting model
(:mod:`.handwriting`) and learned with ``hila learn`` into ``primitives/letters/<L>.yaml``;
``programs/write.hila`` composes them, placing each letter by the scene points of its slot on
the paper (:mod:`.layout`).  The word is a setting (``--set word=HILA``).  The world writes an
image of the paper (``paper.png``) when the program ends.

- :mod:`.shapes` -- the letters as strokes in a unit box (pure Python)
- :mod:`.handwriting` -- the handwriting model and the script that makes the demonstrations
- :mod:`.layout` -- where the paper and the letter slots are
- :mod:`.world` -- the ``letters`` world
"""

from ...plugins.names import Name, Names
from ...plugins.registry import WorldInfo
from ...plugins.settings import Setting, boolean, number
from .shapes import ALPHABET


def _word(text: str) -> str:
    """The word to write: capital letters with a demonstration, and spaces."""
    word = " ".join(text.upper().split())
    unknown = sorted({c for c in word if c != " " and c not in ALPHABET})
    if not word.strip():
        raise ValueError("expected at least one letter")
    if unknown:
        raise ValueError(f"no demonstration of {', '.join(repr(c) for c in unknown)}; the letters are {ALPHABET}")
    return word


WORLD = WorldInfo(
    name="letters",
    factory="hila_lang.worlds.letters.world:make_world",
    doc="the iCub writes a word on paper, one learned template per letter",
    settings=(
        Setting("word", "the word to write (letters A-Z and spaces)", _word, default="HILA", metavar="TEXT"),
        Setting("size", "letter height on the paper, metres", number(0.015, 0.06), default=0.036, metavar="METRES"),
        Setting("report", "write the output folder (paper.png, report.json)", boolean, default=True, metavar="yes|no"),
    ),
    points=Names("point", [
        Name("paper.slotK.tl|tr|br|bl", "the corners of the K-th letter's box on the paper"),
        Name("paper.home", "where the hand waits above the paper"),
    ]),
    questions=Names("question", [
        Name("done", "true when every letter of the word is written", answer="ask_done"),
        Name("next_slot", "the point group of the next letter's box on the paper, e.g. \"paper.slot2\"",
             answer="ask_next_slot"),
        Name("next_letter", "the next letter to write, e.g. \"I\"", answer="ask_next_letter"),
        Name("word", "the word being written", answer="ask_word"),
    ]),
    default_backend="dry",
    drawing_surface=True,
)
