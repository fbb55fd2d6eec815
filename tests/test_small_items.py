"""Issue 23 item 7: game.hila's header tells how circle.yaml was segmented; ``replay --verify``
shows a difference with enough digits to see it; a foul is explained in the game's result line."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hila_lang import cli
from hila_lang.engine.trace import TraceEntry
from hila_lang.session.replay import differing_points, step_difference

ROOT = Path(__file__).resolve().parent.parent


def test_the_game_header_says_what_circle_yaml_says():
    header = "".join(line for line in (ROOT / "programs" / "game.hila").read_text().splitlines(True)
                     if line.startswith("#"))
    assert "k-means" not in header and "dips in the hand's speed" in header
    assert "Segmented at the deepest dips in speed" in (ROOT / "primitives" / "circle.yaml").read_text()


def test_a_difference_is_printed_with_the_digits_that_differ():
    assert differing_points([0.3121, -0.076, 0.672], [0.3124, -0.076, 0.672]) == (
        "(0.3121, -0.0760, 0.6720)", "(0.3124, -0.0760, 0.6720)")
    assert differing_points([0.3, 0.1], [0.301, 0.1]) == ("(0.300, 0.100)", "(0.301, 0.100)")
    recorded = {"state": "s", "kind": "run", "next": None, "icps": {"hand": np.array([0.31200, -0.076, 0.672])},
                "path": None, "executed": None, "value": None, "text": "t"}
    entry = TraceEntry(1, "s", "run", 1, "t", None, icps={"hand": np.array([0.31204, -0.076, 0.672])})
    assert step_difference(recorded, entry, 1e-6) == (
        "ICP hand: recorded (0.31200, -0.07600, 0.67200), now (0.31204, -0.07600, 0.67200) (up to 0.04 mm apart)")


def test_two_circles_in_a_row_say_why_the_game_reads_unfinished(tmp_path, capsys):
    prog = tmp_path / "two.hila"
    prog.write_text("world tictactoe\nimport circle\nmain {\n"
                    "    run circle.reach(board.cell5.*, hand = arm.lift, start = none)\n"
                    "    run circle.draw(board.cell5.*, hand = none)\n"
                    "    run circle.reach(board.cell1.*, hand = arm.lift, start = none)\n"
                    "    run circle.draw(board.cell1.*, hand = none)\n}\n")
    assert cli.main(["exec", str(prog), "--backend", "dry", "--quiet", "--set", "report=no"]) == 0
    result = [line for line in capsys.readouterr().out.splitlines() if line.startswith("result:")]
    assert result == ["result: unfinished -- the referee did not count 1 circle(s): the circle in cell 1 was drawn "
                      "out of turn (the robot drew twice without the opponent playing in between); the game needs a "
                      "move by each side in turn; per-mark R min 1.000"]
