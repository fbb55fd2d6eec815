"""Tic-tac-toe rules, minimax and the opponents (pure Python, fast)."""

from __future__ import annotations

import io
import random

import pytest

from hila_lang.core.errors import HilaRuntimeError, InputError
from hila_lang.worlds.tictactoe import rules as ttt
from hila_lang.worlds.tictactoe.opponents import HumanOpponent, MinimaxOpponent, RandomOpponent, make_opponent


def _board(text: str) -> ttt.Board:
    return tuple("" if ch == "." else ch for ch in text.replace(" ", ""))


def test_winner_lines_and_draw():
    assert ttt.winner(_board("OOO ... ...")) == "O"
    assert ttt.winner(_board("X.. X.. X..")) == "X"
    assert ttt.winner(_board("..O .O. O..")) == "O"
    assert ttt.winner(_board("OXO XOX XOX")) is None
    assert ttt.game_over(_board("OXO XXO OOX"))
    assert not ttt.game_over(_board("OX. ... ..."))
    assert ttt.winning_line(_board("X.. .X. ..X")) == (1, 5, 9)


def test_play_rejects_taken_and_bad_cells():
    b = ttt.play(ttt.empty_board(), 5, "O")
    with pytest.raises(InputError, match="cell 5 is taken"):
        ttt.play(b, 5, "X")
    with pytest.raises(InputError, match="expected a cell 1..9, got 10"):
        ttt.play(b, 10, "X")
    with pytest.raises(InputError, match="expected mark"):
        ttt.play(b, 1, "Z")


def test_minimax_takes_a_win_and_blocks_a_loss():
    assert ttt.best_move(_board("OO. XX. ..."), "O") == 3          # win now
    assert ttt.best_move(_board("O.. XX. ..O"), "O") == 6          # block the row 4-5-6
    assert ttt.best_move(ttt.empty_board(), "O") == 5              # centre first, as the paper's iCub


def test_best_move_on_a_finished_game_is_an_error():
    with pytest.raises(InputError, match="the game is over"):
        ttt.best_move(_board("OOO XX. ..."), "X")


def _reference_value(board, to_move, me):
    """Slow, obvious minimax (win/draw/loss only) to check the fast one against."""
    w = ttt.winner(board)
    if w is not None:
        return 1 if w == me else -1
    if "" not in board:
        return 0
    vals = [_reference_value(ttt.play(board, c, to_move), ttt.other(to_move), me) for c in ttt.free_cells(board)]
    return max(vals) if to_move == me else min(vals)


@pytest.mark.slow
def test_best_move_is_optimal_against_a_reference_on_random_positions():
    rng = random.Random(3)
    checked = 0
    while checked < 40:
        board = ttt.empty_board()
        mark = "O"
        for _ in range(rng.randint(0, 6)):
            if ttt.game_over(board):
                break
            board = ttt.play(board, rng.choice(ttt.free_cells(board)), mark)
            mark = ttt.other(mark)
        if ttt.game_over(board):
            continue
        best = _reference_value(board, mark, mark)
        move = ttt.best_move(board, mark)
        assert _reference_value(ttt.play(board, move, mark), ttt.other(mark), mark) == best
        checked += 1


def _play_all_replies(board, robot_first_mark="O"):
    """Every game the robot (O, minimax) can face: the opponent tries every free cell."""
    if ttt.game_over(board):
        yield board
        return
    placed = 9 - board.count("")
    if placed % 2 == 0:  # robot's turn (robot starts)
        yield from _play_all_replies(ttt.play(board, ttt.best_move(board, "O"), "O"))
    else:
        for c in ttt.free_cells(board):
            yield from _play_all_replies(ttt.play(board, c, "X"))


def test_robot_never_loses_against_any_opponent():
    finals = list(_play_all_replies(ttt.empty_board()))
    assert len(finals) > 50
    assert all(ttt.winner(b) != "X" for b in finals)
    assert any(ttt.winner(b) == "O" for b in finals)


def test_robot_never_loses_when_the_opponent_starts():
    def games(board):
        if ttt.game_over(board):
            yield board
            return
        if (9 - board.count("")) % 2 == 0:  # opponent's turn (it started)
            for c in ttt.free_cells(board):
                yield from games(ttt.play(board, c, "X"))
        else:
            yield from games(ttt.play(board, ttt.best_move(board, "O"), "O"))

    finals = list(games(ttt.empty_board()))
    assert all(ttt.winner(b) != "X" for b in finals)


def test_render_shows_numbers_in_free_cells():
    text = ttt.render(_board("O.X .O. ..X"))
    assert text.splitlines()[0] == " O | 2 | X"
    assert text.splitlines()[4] == " 7 | 8 | X"


@pytest.mark.parametrize("cls", [RandomOpponent, MinimaxOpponent])
def test_builtin_opponents_are_seeded_and_play_free_cells(cls):
    board = _board("O.. .X. ..O")
    a = [cls(seed=s).choose(board) for s in range(12)]
    b = [cls(seed=s).choose(board) for s in range(12)]
    assert a == b
    assert all(board[c - 1] == "" for c in a)


def test_random_opponent_varies_with_seed_and_minimax_opponent_is_optimal():
    board = ttt.play(ttt.empty_board(), 5, "O")
    assert len({RandomOpponent(seed=s).choose(board) for s in range(30)}) > 3
    moves = {MinimaxOpponent(seed=s).choose(board) for s in range(30)}
    assert moves <= {1, 3, 7, 9}  # against a centre opening only corners hold the draw
    assert len(moves) > 1


def test_human_opponent_asks_again_after_bad_input():
    board = _board("O.. ... ...")
    out = io.StringIO()
    human = HumanOpponent(io.StringIO("hello\n12\n1\n\n  4 \n"), out)
    assert human.choose(board) == 4
    text = out.getvalue()
    assert "'hello' is not a cell number" in text
    assert "there is no cell 12" in text
    assert "cell 1 is taken" in text
    assert text.count("your move") == 5


def test_human_opponent_end_of_input_is_a_clear_error():
    with pytest.raises(InputError, match="input ended while waiting for a cell number"):
        HumanOpponent(io.StringIO("x\n"), io.StringIO()).choose(ttt.empty_board())


def test_human_opponent_can_quit():
    with pytest.raises(HilaRuntimeError, match="quit"):
        HumanOpponent(io.StringIO("q\n"), io.StringIO()).choose(ttt.empty_board())


def test_unknown_opponent_suggests_a_name():
    with pytest.raises(InputError, match="unknown opponent 'minmax'") as err:
        make_opponent("minmax")
    assert "did you mean 'minimax'" in str(err.value)
    assert make_opponent(None).name == "minimax"
