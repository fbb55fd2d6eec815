"""``hila show`` (issue 23 item 1): a template's tags, spans, contact, ICPs and a picture of its
path with its cuts; a world's points, questions, events and settings from its declared table."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.commands.show import picture
from hila_lang.osila.template import Segment, Template


def show(capsys, *args) -> tuple[int, list[str], str]:
    code = cli.main(["show", *args])
    out, err = capsys.readouterr()
    return code, out.splitlines(), err


def test_show_circle_prints_its_tags_spans_contact_and_icps(capsys, monkeypatch, tmp_path):
    code, out, err = show(capsys, "circle", "--plot", str(tmp_path / "c.png"))
    assert code == 0 and err == ""
    assert out[0].startswith("template circle (") and out[0].endswith("): 3-D, 84 points over 4.15 s, metres")
    assert out[out.index("tags (sub-templates: run circle.TAG(ICP = point, ...)):") + 1:][:3] == [
        "  1 reach    points 0..24     (25 samples)  0.00-1.20 s  pen up",
        "  2 draw     points 25..56    (32 samples)  1.25-2.80 s  pen down",
        "  3 retract  points 57..83    (27 samples)  2.85-4.15 s  pen up"]
    icps = out.index("ICPs (metres; bind them by name, e.g. run circle.reach(tl = ...)):")
    assert out[icps + 1:icps + 6] == ["  A tl    (+0.353, -0.036, +0.371)", "  B tr    (+0.353, -0.103, +0.371)",
                                      "  C br    (+0.286, -0.103, +0.371)", "  D bl    (+0.286, -0.036, +0.371)",
                                      "  E hand  (+0.204, -0.174, +0.568)"]
    frame = out.index("path from above, the paper as the robot sees it: farther up, its right to the right: digits = "
                      "the tag's points, | = a cut, letters = ICPs, * = start")
    rows = out[frame + 1:]
    # the whole path, then the circle again, fitted (it is small beside the hand's start), then the plot
    assert len(rows) == 18 + 2 + 18 + 1 and rows[0] == "  +" + "-" * 56 + "+" and rows[-1] == "plot written to " + str(
        tmp_path / "c.png")
    assert rows[19] == "the drawing (pen down), zoomed to fit:"
    body = "".join(r[3:-1] for r in rows[1:17])  # inside the frame
    assert all(ch in body for ch in "123|ABCD*")  # E, the hand, is where the path starts: drawn as *
    import cv2

    image = cv2.imread(str(tmp_path / "c.png"))
    assert image is not None and image.shape[0] > 400 and (image < 128).any()


def test_the_picture_puts_cuts_icps_and_start_where_they_are():
    """A straight line from y=1 to y=0 (the robot's left to its right) cut at its middle: the cut
    is in the middle column; an ICP ahead (x) is above it."""
    path = np.column_stack([np.zeros(11), np.linspace(1, 0, 11), np.zeros(11)])
    t = Template("line", path, {"a": np.array([0.5, 1.0, 0.0])},
                 segments=[Segment("one", 0, 5), Segment("two", 5, 11)])
    rows = picture(t, columns=21, rows=11)
    line = next(r for r in rows if "*" in r)
    assert line == "|* 1 1 1 1 | 2 2 2 2 2|"  # start, tag 1, the cut at x = 0.5, tag 2
    assert any("A" in r for r in rows) and rows.index(next(r for r in rows if "A" in r)) < rows.index(line)


def test_show_an_unknown_template_says_did_you_mean(capsys):
    code, out, err = show(capsys, "circel")
    assert code == 2 and "error: template 'circel' not found" in err and "hint: did you mean 'circle'?" in err


def test_show_world_tictactoe_prints_its_table(capsys):
    code, out, err = show(capsys, "world", "tictactoe")
    assert code == 0 and err == ""
    assert out[0] == "world tictactoe: the paper's Experiment B: the iCub plays O on a rotated grid against an opponent"
    assert out[1] == "default back end: pybullet; drawing surface (paper, for 2-D templates): yes"
    assert "  board.cellN.tl|tr|br|bl        the corners of cell N (1..9) as the robot last saw them" in out
    assert "  arm.lift                       straight above the pen at the park height" in out
    q = out.index("questions (ask NAME):")
    assert out[q + 1] == "  game_over                      true when someone has won or the board is full"
    assert "  free(N)                        true when cell N (1..9) is empty" in out
    e = out.index("events (wait NAME):")
    assert out[e + 1].startswith("  opponent_moved                 the opponent plays a cell")
    assert "  opponent=random|minimax|human  who plays X (default: minimax); also --opponent" in out
    from hila_lang.plugins import registry

    info = registry.world("tictactoe")
    for name in list(info.questions) + list(info.events):  # every declared name, from the one table
        assert any(line.startswith(f"  {name}") for line in out), name


def test_show_world_letters_and_scripted_and_the_list(capsys):
    code, out, _ = show(capsys, "world", "letters")
    assert code == 0 and "  next_slot                the point group of the next letter's box on the paper, e.g." in out
    assert out[out.index("events (wait NAME):") + 1] == "  none"
    code, out, _ = show(capsys, "world", "scripted")
    assert code == 0 and "  whatever the running world names (its script: --set script=FILE.yaml)" in out
    code, out, _ = show(capsys, "world")
    assert code == 0 and out[0].startswith("worlds") and any(r.startswith("  tictactoe  ") for r in out)
    code, _, err = show(capsys, "world", "tictactoo")
    assert code == 2 and "did you mean 'tictactoe'?" in err


# --------------------------------------------------------------------------- one orientation, the mark fitted (issue 30 item 8)


def test_a_two_d_drawing_is_shown_the_way_up_it_was_drawn():
    """A 2-D template is a drawing on a sheet (x right, y up), laid on the robot's paper that way
    (its right, farther): an L drawn down then right is shown down then right -- before, 2-D
    paths were turned a quarter (x up, y to the left)."""
    down = np.column_stack([np.zeros(11), np.linspace(1, 0, 11)])
    right = np.column_stack([np.linspace(0, 0.6, 7), np.zeros(7)])[1:]
    t = Template("L", np.vstack([down, right]), {"a": np.array([0.0, 1.0])},
                 segments=[Segment("down", 0, 11, True), Segment("right", 11, 17, True)])
    rows = [r[1:-1] for r in picture(t, columns=21, rows=11)[1:-1]]
    column = rows[0].index("*")  # the start (and the ICP under it), top left
    assert all(r[column] in "1|" for r in rows[1:])  # the down stroke: one column, top to bottom
    assert rows[-1][column:].split() == ["1", "|", "2", "2", "2", "2", "2"]  # the foot: to the right, along the bottom


def test_a_small_mark_is_shown_again_fitted_and_the_description_whole(tmp_path, capsys):
    """The hand's start 20 cm away set the picture's scale: the triangle was a few characters.
    Now the pen-down part is shown again fitted, and the description's last sentence (how the
    cuts were made: moved by hand) is printed too."""
    from hila_lang.worlds.tictactoe.drawing import draw_mark, write_demonstration

    demo, icps = write_demonstration(tmp_path, "tri", draw_mark("triangle", "small", seed=0))
    out = tmp_path / "tri.yaml"
    assert cli.main(["learn", str(demo), "--icps", str(icps), "--tags", "reach,draw,retract", "--cuts", "17,40",
                     "-o", str(out)]) == 0
    capsys.readouterr()
    code, lines, err = show(capsys, str(out), "--plot", str(tmp_path / "tri.png"))
    text = "\n".join(lines)
    assert code == 0 and "Cut by hand at samples 17, 40 (--cuts; k = 3)." in " ".join(r.strip() for r in lines)
    zoomed = lines[lines.index("the drawing (pen down), zoomed to fit:") + 1:]
    drawn = [r for r in zoomed[1:17] if "2" in r]
    assert len(drawn) >= 8  # the triangle fills the zoomed picture (half as many rows as columns: a character is tall)
    whole = lines[lines.index(next(r for r in lines if r.startswith("path from above"))) + 1:][1:17]
    assert sum("2" in r for r in whole) <= 4  # in the whole path's picture it was a few rows
    import cv2

    image = cv2.imread(str(tmp_path / "tri.png"))
    assert image.shape[1] == 3 * 460  # top, the drawing zoomed, side
    assert "tags (sub-templates" in text


def test_labels_are_placed_apart():
    """Four ICP labels at points a few pixels apart (a cell's corners when the hand sets the
    scale) get boxes that do not overlap."""
    from hila_lang.session.plot import _Labels

    img = np.full((200, 200, 3), 255, np.uint8)
    labels = _Labels()
    for name, at in (("tl", (100, 100)), ("tr", (104, 100)), ("bl", (100, 104)), ("br", (104, 104)), ("hand", (102, 102))):
        labels.put(img, name, at, (0, 0, 0), (0, 0, 200, 200))
    boxes = labels.boxes
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert min(a[2], b[2]) <= max(a[0], b[0]) or min(a[3], b[3]) <= max(a[1], b[1]), (a, b)
