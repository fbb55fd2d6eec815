"""The second world: the iCub writes a word, one learned template per letter.

The letters' positions are read back from the paper image the world writes, and compared with
where the layout's documented geometry puts them (computed here from the constants, not taken
from the world's report); each letter's ink is checked for the strokes that make it that letter.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.osila.demofile import load_icps, read_demo_csv
from hila_lang.osila.template import load_template
from hila_lang.worlds.letters import WORLD
from hila_lang.worlds.letters.handwriting import write_letter
from hila_lang.worlds.letters.layout import ASPECT, GAP, PAPER, layout
from hila_lang.worlds.letters.shapes import ALPHABET

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = ROOT / "programs" / "write.hila"
LETTERS = ROOT / "primitives" / "letters"
PPM = 2000.0  # the paper texture's pixels per metre


def _read_letters(png: Path) -> list[tuple[int, int, int, int]]:
    """Bounding boxes (col0, col1, row0, row1) of the ink blobs in a paper image, left to right:
    columns with ink, split where at least 1 mm of paper separates them."""
    import cv2

    bgr = cv2.imread(str(png))
    assert bgr is not None and bgr.shape == (round(PAPER.size[1] * PPM), round(PAPER.size[0] * PPM), 3)
    ink = (bgr[:, :, 0].astype(int) - bgr[:, :, 2].astype(int)) > 80  # blue ink on white paper
    cols = np.flatnonzero(ink.any(axis=0))
    assert len(cols), "no ink on the paper"
    runs, start = [], cols[0]
    for a, b in zip(cols[:-1], cols[1:]):
        if b - a > 0.001 * PPM:
            runs.append((start, a))
            start = b
    runs.append((start, cols[-1]))
    boxes = []
    for c0, c1 in runs:
        rows = np.flatnonzero(ink[:, c0:c1 + 1].any(axis=1))
        boxes.append((int(c0), int(c1), int(rows[0]), int(rows[-1])))
    return boxes, ink


def _expected_boxes(word: str, height: float):
    """Slot boxes in pixels (col0, col1, row0, row1) from the documented geometry: letters of
    ``height`` with the demonstrations' aspect, ``GAP`` heights apart, centred on the sheet."""
    width, gap = ASPECT * height, GAP * height
    total = len(word) * width + (len(word) - 1) * gap
    across, depth = PAPER.size
    out = []
    for i, c in enumerate(word):
        if c != " ":
            left = -total / 2 + i * (width + gap)
            out.append(((left + across / 2) * PPM, (left + width + across / 2) * PPM,
                        (depth / 2 - height / 2) * PPM, (depth / 2 + height / 2) * PPM))
    return out


def _looks_like(letter: str, ink: np.ndarray) -> None:
    """The strokes that make ``letter`` are there (its ink crop, rows top to bottom)."""
    h, w = ink.shape
    band = lambda r0, r1, c0, c1: ink[int(r0 * h):int(r1 * h) + 1, int(c0 * w):int(c1 * w) + 1].any()  # noqa: E731
    if letter == "H":  # two full-height uprights and a bar between them
        for r in (0.1, 0.3, 0.7, 0.9):
            assert band(r, r + 0.05, 0.0, 0.15) and band(r, r + 0.05, 0.85, 1.0), r
        assert band(0.4, 0.6, 0.4, 0.6) and not band(0.05, 0.35, 0.4, 0.6)
    elif letter == "I":  # top and bottom bars, one upright in the middle
        assert band(0.0, 0.1, 0.0, 0.2) and band(0.9, 1.0, 0.8, 1.0) and band(0.4, 0.6, 0.4, 0.6)
        assert not band(0.3, 0.7, 0.0, 0.25) and not band(0.3, 0.7, 0.75, 1.0)
    elif letter == "L":  # an upright on the left, a foot along the bottom, nothing top right
        assert band(0.1, 0.9, 0.0, 0.15) and band(0.88, 1.0, 0.8, 1.0)
        assert not band(0.0, 0.7, 0.35, 1.0)
    elif letter == "A":  # an apex in the middle of the top, legs at the bottom corners
        assert band(0.0, 0.08, 0.35, 0.65) and not band(0.0, 0.2, 0.0, 0.2) and not band(0.0, 0.2, 0.8, 1.0)
        assert band(0.9, 1.0, 0.0, 0.15) and band(0.9, 1.0, 0.85, 1.0)
    else:  # pragma: no cover - only the letters above are asked for
        raise AssertionError(letter)


def _check_paper(png: Path, word: str, height: float = 0.036) -> None:
    boxes, ink = _read_letters(png)
    expected = _expected_boxes(word, height)
    assert len(boxes) == len(expected), (boxes, expected)
    pen = 0.003 * PPM  # a pen line's width, plus tremor and the route's freedom
    for letter, (c0, c1, r0, r1), (e0, e1, f0, f1) in zip(word.replace(" ", ""), boxes, expected):
        assert e0 - pen <= c0 and c1 <= e1 + pen and f0 - pen <= r0 and r1 <= f1 + pen, (letter, (c0, c1, r0, r1))
        assert abs((c0 + c1) / 2 - (e0 + e1) / 2) < 0.003 * PPM  # centred in its slot within 3 mm
        assert (r1 - r0) > 0.8 * (f1 - f0)  # as tall as the slot
        _looks_like(letter, ink[r0:r1 + 1, c0:c1 + 1])


def test_write_hila_on_the_dry_back_end_and_read_the_letters_back(tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["exec", str(PROGRAM), "--set", "word=HILA", "--out", str(out), "--quiet"]) == 0
    assert "wrote 'HILA'" in capsys.readouterr().out
    _check_paper(out / "paper.png", "HILA")
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] and [x["template"] for x in report["letters"]] == list("HILA")
    assert all(x["contact_points"] > 20 for x in report["letters"])


def test_write_on_the_pybullet_robot(tmp_path, capsys):
    pytest.importorskip("pybullet")
    out = tmp_path / "out"
    assert cli.main(["exec", str(PROGRAM), "--backend", "pybullet", "--set", "word=LA HI", "--out", str(out),
                     "--quiet"]) == 0
    assert "wrote 'LA HI'" in capsys.readouterr().out
    _check_paper(out / "paper.png", "LA HI")  # the ink the robot's pen left in the simulation


def test_the_word_is_a_checked_setting(tmp_path, capsys):
    assert cli.main(["exec", str(PROGRAM), "--set", "word=hé", "--quiet"]) == 2
    assert "bad value for --set word=hé (world letters): no demonstration of 'É'" in capsys.readouterr().err
    assert cli.main(["exec", str(PROGRAM), "--set", "word=ABCDEFGHIJ", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "the word 'ABCDEFGHIJ' needs" in err and "7 characters fit" in err and "hint: shorten it, or set size=" in err
    assert WORLD.parse({"word": "  hi   la "})["word"] == "HI LA"
    assert cli.main(["exec", str(PROGRAM), "--set", "word=ABCDEFGHIJ", "--set", "size=0.02", "--set", "report=no",
                     "--quiet"]) == 0
    assert "wrote 'ABCDEFGHIJ'" in capsys.readouterr().out


@pytest.mark.parametrize("letter", list(ALPHABET))
def test_each_template_is_hila_learn_of_one_demonstration(letter):
    t = load_template(LETTERS / f"{letter}.yaml")
    demo, times = read_demo_csv(LETTERS / "demos" / f"{letter}.csv")
    icps = load_icps(LETTERS / "demos" / "box.yaml", 3)
    assert t.name == letter and list(t.icps) == ["tl", "tr", "br", "bl"]
    np.testing.assert_array_equal(t.path, demo)
    np.testing.assert_array_equal(t.times, times)
    for k in icps:
        np.testing.assert_array_equal(t.icps[k], icps[k])
    assert [(s.tag, s.start, s.stop, s.contact) for s in t.segments] == [("write", 0, len(demo), True)]
    assert "ONE demonstration by the seeded handwriting model" in t.description
    path, again, contact = write_letter(letter, 0)  # the model makes the same demonstration again
    np.testing.assert_allclose(path, demo, atol=1e-6)
    assert contact.sum() > 0.4 * len(path) and not contact[0] and not contact[-1]  # pen down, lifted at the ends


def test_a_program_without_a_letter_stops_instead_of_looping(tmp_path, capsys):
    program = tmp_path / "p.hila"
    program.write_text(f'world letters\nimport "{LETTERS / "H.yaml"}" as H\n'
                       "main { until ask done { let s = ask next_slot\n let ch = ask next_letter\n"
                       ' if ch == "H" { run H(s.*) } } }\n')
    assert cli.main(["exec", str(program), "--set", "word=HI", "--set", "report=no", "--quiet"]) == 1
    assert "letter 2 ('I') was asked for 3 times and never written" in capsys.readouterr().err
    program.write_text(f'world letters\nimport "{LETTERS / "H.yaml"}" as H\n'
                       "main { run H(paper.slot1.*) }\n")
    assert cli.main(["exec", str(program), "--set", "word=IH", "--set", "report=no", "--quiet"]) == 1
    assert "the template 'H' wrote in the box of letter 1 ('I')" in capsys.readouterr().err


def test_layout_reads_from_the_robots_left_to_its_right():
    lay = layout("AB C", 0.03)
    assert [s["letter"] for s in lay.slots] == ["A", "B", "C"]
    lefts = [s["corners"]["tl"][1] for s in lay.slots]
    assert lefts[0] > lefts[1] > lefts[2]  # the robot's right is -y
    for s in lay.slots:
        c = s["corners"]
        assert c["tl"][0] > c["bl"][0] and np.isclose(np.linalg.norm(c["tl"] - c["bl"]), 0.03)
        assert np.isclose(np.linalg.norm(c["tr"] - c["tl"]), ASPECT * 0.03)
    gap_bc = lay.slots[1]["corners"]["tr"][1] - lay.slots[2]["corners"]["tl"][1]
    assert np.isclose(gap_bc, 0.03 * (2 * GAP + ASPECT))  # a space is an empty box
