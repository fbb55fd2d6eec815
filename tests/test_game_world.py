"""The tic-tac-toe world and whole games of programs/game.hila on the dry back end (fast)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import HilaRuntimeError, InputError, UnknownNameError
from hila_lang.worlds.tictactoe import rules as ttt
from hila_lang.worlds.tictactoe import WORLD
from hila_lang.plugins.options import RunOptions
from hila_lang.session.runner import finish, prepare
from hila_lang.worlds.tictactoe.board import cell_at

ROOT = Path(__file__).resolve().parents[1]
PROGRAM = ROOT / "programs" / "game.hila"


def _options(tmp_path, seed=0, opponent="minimax", stdin="", **settings):
    return RunOptions(seed=seed, out=tmp_path / f"out{seed}{opponent}", settings={"opponent": opponent, **settings},
                      stdin=io.StringIO(stdin), stdout=io.StringIO())


def _world(tmp_path, **settings):
    options = _options(tmp_path, **settings)
    return WORLD.build(options, WORLD.parse(options.settings))


def play(tmp_path, seed=0, opponent="minimax", stdin="", **settings):
    """A whole game on the dry back end: (world, report, printed text)."""
    options = _options(tmp_path, seed, opponent, stdin, **settings)
    interp = prepare(PROGRAM, options, "dry")
    interp.run()
    report = finish(interp)
    return interp.world, report, options.stdout.getvalue()


@pytest.mark.parametrize("opponent", ["random", "minimax"])
@pytest.mark.parametrize("seed", [0, 1, 2, 7])
def test_whole_dry_game(tmp_path, seed, opponent):
    world, report, text = play(tmp_path, seed, opponent)
    assert ttt.game_over(world.board)
    assert report["result"] in ("robot", "draw")            # the robot never loses
    if opponent == "minimax":
        assert report["result"] == "draw"                    # two perfect players draw
    # the board is what the moves say, and the robot opened in the centre
    replay = ttt.empty_board()
    for move in report["moves"]:
        replay = ttt.play(replay, move["cell"], move["mark"])
    assert list(replay) == report["board"] == list(world.board)
    assert report["moves"][0] == {**report["moves"][0], "player": "robot", "cell": 5}
    # every circle was drawn where minimax wanted it, inside its cell, like the demonstration
    robot_moves = [m["cell"] for m in report["moves"] if m["player"] == "robot"]
    assert [m["cell"] for m in report["marks"]] == robot_moves
    for mark in report["marks"]:
        assert mark["cell"] == mark["intended_cell"]
        assert mark["outside_cell_mm"] == 0.0
        assert mark["contact_points"] >= 20
        assert mark["r"] >= 0.95
    # the board was printed after every move, then the result
    assert text.count("plays cell") == len(report["moves"])
    assert "result:" in text


def test_no_retract_between_marks_and_one_at_the_end(tmp_path):
    world, report, _ = play(tmp_path, 1, "minimax")
    runs = [s["state"] for s in world.states]
    robot_marks = len(report["marks"])
    assert runs == ["main/mark/reach", "main/mark/draw"] * robot_marks + ["main/retract"]
    pen = [s["pen_down"] for s in world.states]
    assert pen == [False, True] * robot_marks + [False]


def test_reach_starts_straight_above_the_pen(tmp_path):
    """After a circle, the next reach starts at the park height above where the pen was."""
    world, _, _ = play(tmp_path, 2, "random")
    draws = [s for s in world.states if s["pen_down"]]
    reaches = [s for s in world.states if s["state"].endswith("reach")]
    # within OSILA's distortion threshold (the route may pick a candidate near the mapped point)
    np.testing.assert_allclose(reaches[0]["planned"][0], world.park, atol=2e-3)
    for draw, reach in zip(draws, reaches[1:]):
        start = reach["planned"][0]
        np.testing.assert_allclose(start[:2], draw["planned"][-1][:2], atol=2e-3)
        assert start[2] == pytest.approx(world.park[2], abs=2e-3)
        assert start[2] - draw["planned"][-1][2] > 0.02   # a real lift, not a slide


def test_same_seed_same_game_other_seed_other_park(tmp_path):
    a, ra, _ = play(tmp_path / "a", 3, "random")
    b, rb, _ = play(tmp_path / "b", 3, "random")
    c, _, _ = play(tmp_path / "c", 4, "random")
    assert [m["cell"] for m in ra["moves"]] == [m["cell"] for m in rb["moves"]]
    np.testing.assert_array_equal(a.states[3]["planned"], b.states[3]["planned"])
    assert not np.allclose(a.park, c.park)
    for w in (a, c):  # parked above the grid
        assert cell_at(w.spec, w.park) is not None
        assert 0.08 <= w.park[2] - w.spec.surface_z <= 0.13


def test_output_folder(tmp_path):
    world, report, _ = play(tmp_path, 0, "random")
    folder = Path(report["out"])
    on_disk = json.loads((folder / "report.json").read_text())
    assert on_disk["result"] == report["result"]
    assert on_disk["files"] == ["fsm.dot", "paper.png", "report.json", "top.png", "traces.csv"]  # no camera on the dry back end
    assert (folder / "fsm.dot").read_text().startswith("digraph hila {")
    assert on_disk["wall_time_s"] > 0
    assert on_disk["vision"]["board_read_by"] == "memory" and world.sightings == []  # no cameras
    csv = (folder / "traces.csv").read_text().splitlines()
    assert csv[0] == "source,state,pen_down,kind,index,x,y,z"
    crosses = {line.split(",")[1] for line in csv if line.startswith("opponent,")}
    assert len(crosses) == 2 * sum(m["player"] == "opponent" for m in report["moves"])
    import cv2

    top = cv2.imread(str(folder / "top.png"))
    assert top is not None and top.shape[0] > 400


def test_opponent_first(tmp_path):
    world, report, _ = play(tmp_path, 5, "random", first="opponent")
    assert report["moves"][0]["player"] == "opponent"
    assert report["result"] in ("robot", "draw")


def test_human_opponent_through_stdin(tmp_path):
    # bad input is asked again; the person plays 1, then 2 (after two mistakes), ...
    world, report, text = play(tmp_path, 0, "human", stdin="1\nfive\n5\n2\n3\n4\n6\n7\n8\n9\n")
    assert "'five' is not a cell number" in text and "cell 5 is taken" in text
    opp = [m["cell"] for m in report["moves"] if m["player"] == "opponent"]
    assert opp[:2] == [1, 2]
    assert report["result"] in ("robot", "draw")


def test_human_opponent_end_of_input_is_a_clear_error(tmp_path):
    options = _options(tmp_path, 0, "human", stdin="1\n")
    interp = prepare(PROGRAM, options, "dry")
    with pytest.raises(HilaRuntimeError, match="input ended while waiting for a cell number"):
        interp.run()


def test_world_questions_and_mistakes(tmp_path):
    world = _world(tmp_path)
    assert world.query("game_over") is False
    assert world.query("robot_to_move") is True
    assert world.query("best_move") == "board.cell5"
    assert world.query("free", 3) is True
    pts = world.points()
    assert {"board.cell1.tl", "board.cell9.br", "board.move.tl", "arm.park", "arm.lift"} <= set(pts)
    with pytest.raises(UnknownNameError, match="the tictactoe world has no question 'score'"):
        world.query("score")
    with pytest.raises(UnknownNameError, match="no event 'opponent_move'") as info:
        world.wait("opponent_move")
    assert info.value.hint == "did you mean 'opponent_moved'?"
    with pytest.raises(InputError, match="expects a cell 1..9"):
        world.query("free", 10)
    with pytest.raises(HilaRuntimeError, match="it is the robot's turn"):
        world.wait("opponent_moved")
    with pytest.raises(InputError, match=r"bad value for --set first=nobody \(world tictactoe\): expected robot\|opponent"):
        _world(tmp_path, first="nobody")
    with pytest.raises(InputError, match=r"--set report=maybe .*expected yes or no"):
        _world(tmp_path, report="maybe")


def test_a_circle_outside_the_grid_is_a_runtime_error(tmp_path):
    world = _world(tmp_path)
    far = np.array([[1.0, 1.0, world.spec.surface_z]] * 5)
    with pytest.raises(HilaRuntimeError, match="outside the grid"):
        world.notify("state_done", state="x/draw", path=far, executed=far, kind="run", pen_down=True)


def test_cli_exec_dry_and_bad_opponent(tmp_path, capsys):
    out = tmp_path / "cli"
    code = cli.main(["exec", str(PROGRAM), "--backend", "dry", "--seed", "1", "--opponent", "random",
                     "--out", str(out), "--quiet"])
    assert code == 0
    assert json.loads((out / "report.json").read_text())["result"] in ("robot", "draw")
    assert "result:" in capsys.readouterr().out
    code = cli.main(["exec", str(PROGRAM), "--backend", "dry", "--opponent", "minmax", "--quiet"])
    assert code == 2
    err = capsys.readouterr().err
    assert "bad value for --set opponent=minmax" in err and "did you mean 'minimax'" in err
    assert "Traceback" not in err


def test_repl_steps_the_game_with_moves_typed_at_the_prompt(tmp_path):
    """The REPL and the human opponent read the same piped stdin, as in a terminal session."""
    from hila_lang.session.repl import Repl

    script = "step 3\nwhere\nrun\n1\n" + "step 3\n" + "run\n2\nrun\n9\nrun\n7\nrun\n6\nrun\n4\nquit\n"
    options = _options(tmp_path, 0, "human", stdin=script)
    interp = prepare(PROGRAM, options, "dry")
    Repl(interp, stdin=options.stdin, stdout=options.stdout).cmdloop()
    report = finish(interp)
    text = options.stdout.getvalue()
    # after 3 steps the robot has chosen the centre and is about to call mark
    first = text.index("(hila) step 3")
    assert "set c = \"board.cell5\"" in text[first:text.index("(hila) where")]
    assert "at main/mark" in text[first:]
    assert text.count("your move") >= 2
    opp = [m["cell"] for m in report["moves"] if m["player"] == "opponent"]
    assert opp[:2] == [1, 2]
    assert ttt.game_over(interp.world.board) and report["result"] in ("robot", "draw")


def test_out_on_a_file_is_refused_before_the_game(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    code = cli.main(["exec", str(PROGRAM), "--backend", "dry", "--out", str(tmp_path / "file"), "--quiet"])
    captured = capsys.readouterr()
    assert code == 2 and f"{tmp_path / 'file'}: error: expected a folder, got a file" in captured.err
    assert "plays cell" not in captured.out and "Traceback" not in captured.err


def test_the_record_is_sealed_while_the_robot_decides(tmp_path):
    """Reading the game's record while the world answers the robot's questions or names its
    points is an error, so no decision can come from it (the games here and in
    test_game_vision.py run with the seal on); outside a decision the referee reads it freely."""
    from hila_lang.worlds.tictactoe.referee import SealedRecordError

    world = _world(tmp_path)
    assert world.query("best_move") == "board.cell5" and world.board == ttt.empty_board()
    world.player.board = lambda: world.board  # a robot that peeks at the record
    with pytest.raises(SealedRecordError, match=r"the game's record \(board\) was read while the robot was deciding"):
        world.query("game_over")
    with pytest.raises(SealedRecordError):
        world.points()
    assert world.board == ttt.empty_board()  # unsealed again


def test_a_blind_robot_plays_from_the_moves_it_made_and_was_told(tmp_path):
    """On the dry back end (no eyes) the robot's board is its own memory: a record made wrong
    does not change what it plays, and the referee's fouls say what went wrong."""
    options = _options(tmp_path, 0, "minimax")
    interp = prepare(PROGRAM, options, "dry")
    world = interp.world
    world.referee.record.board = ("", "", "", "", "X", "", "", "", "")
    while not world.marks:
        interp.step()
    assert world.player.own == [5] and world.marks[0]["cell"] == 5
    assert world.referee.fouls == [{"cell": 5, "foul": "drawn over X", "moves_before": 0}]
    assert world.board[4] == "X"  # the record keeps the cell's first mark


@pytest.mark.parametrize("setting", ["board.bump=0.03", "light=0.5"])
def test_perturbations_need_a_back_end_that_can_show_them(tmp_path, capsys, setting):
    code = cli.main(["exec", str(PROGRAM), "--backend", "dry", "--set", setting, "--quiet", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and "changes the scene between moves" in err and "back end 'dry' has no eyes" in err
    assert "Traceback" not in err


def test_exec_help_names_every_setting(capsys):
    with pytest.raises(SystemExit):
        cli.main(["exec", "--help"])
    text = capsys.readouterr().out
    for name in ("board.bump=D", "light=F", "crosses=neat|sloppy", "eyes.noise=SIGMA", "opponent=random|minimax|human"):
        assert name in text, name


@pytest.mark.parametrize("backend", ["dry", pytest.param("pybullet", marks=pytest.mark.slow)])
def test_back_restores_the_game_so_the_same_steps_play_again(tmp_path, backend):
    """The REPL's ``back`` over a robot move and an opponent move: the referee's record and scores,
    the robot's memory and the opponent's generator go back too, so stepping again gives the same
    entries and no foul (a circle over a mark the record still held would be one)."""
    options = _options(tmp_path, seed=3, opponent="random")
    interp = prepare(PROGRAM, options, backend)
    world = interp.world
    assert interp.keep_history() is None
    try:
        first = [interp.step().text for _ in range(14)]
        record = (list(world.board), len(world.moves), len(world.marks), len(world.sightings))
        again = first[-9:]
        interp.back(9)
        assert [interp.step().text for _ in range(9)] == again
        assert (list(world.board), len(world.moves), len(world.marks), len(world.sightings)) == record
        interp.run()
    finally:
        report = finish(interp)
    assert report["fouls"] == [] and report["result"] in ("robot", "draw")
    assert len(report["marks"]) == sum(m["player"] == "robot" for m in report["moves"])
