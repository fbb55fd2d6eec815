"""Tic-tac-toe rules and a minimax player that never loses.

The board is a tuple of 9 strings, cell 1 first (row-major as the robot sees the grid: cell 1 is
far-left, cell 9 near-right, see :mod:`hila_lang.worlds.tictactoe.board`).  An entry is ``""`` (empty),
``"O"`` (the robot's mark, whatever shape it was taught: a circle in the paper's experiment),
``"X"`` (the opponent's cross) or, on a board as the robot read it, ``"?"`` (ink it could not tell:
the cell is taken, by neither side as far as the robot knows; it never completes a line).  Cells
are numbered 1..9 everywhere in this module's interface.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Sequence

from ...core.errors import InputError

EMPTY, CIRCLE, CROSS, UNCLEAR = "", "O", "X", "?"
#: each mark in words, for messages
NAMES = {EMPTY: "empty", CIRCLE: "the robot's mark (O)", CROSS: "a cross (X)", UNCLEAR: "ink it could not tell (?)"}
#: the three-in-a-row lines, as 0-based indices
LINES = (
    (0, 1, 2), (3, 4, 5), (6, 7, 8),
    (0, 3, 6), (1, 4, 7), (2, 5, 8),
    (0, 4, 8), (2, 4, 6),
)
#: preference among equally good moves (the paper's iCub opened in the centre): centre, corners, edges
PREFERENCE = (5, 1, 3, 7, 9, 2, 4, 6, 8)

Board = tuple[str, ...]


def empty_board() -> Board:
    """A board with nine empty cells."""
    return (EMPTY,) * 9


def check_board(board: Sequence[str]) -> Board:
    """Return ``board`` as a tuple of 9 marks; :class:`InputError` for anything else."""
    board = tuple(board)
    if len(board) != 9 or any(m not in (EMPTY, CIRCLE, CROSS, UNCLEAR) for m in board):
        raise InputError(f"expected a board of 9 marks in {{'', 'O', 'X', '?'}}, got {board!r}")
    return board


def free_cells(board: Board) -> list[int]:
    """The empty cells, 1..9, ascending."""
    return [i + 1 for i, m in enumerate(board) if m == EMPTY]


def play(board: Board, cell: int, mark: str) -> Board:
    """The board after ``mark`` is put in ``cell`` (1..9).

    Raises
    ------
    InputError
        ``cell`` is not 1..9, is taken, or ``mark`` is not ``"O"``/``"X"``.
    """
    if mark not in (CIRCLE, CROSS):
        raise InputError(f"expected mark 'O' or 'X', got {mark!r}")
    if isinstance(cell, bool) or not isinstance(cell, int) or not 1 <= cell <= 9:
        raise InputError(f"expected a cell 1..9, got {cell!r}")
    if board[cell - 1] != EMPTY:
        raise InputError(f"cell {cell} is taken (it holds {board[cell - 1]!r})")
    out = list(board)
    out[cell - 1] = mark
    return tuple(out)


def winner(board: Board) -> str | None:
    """``"O"`` or ``"X"`` when that mark has three in a row, else None."""
    line = winning_line(board)
    return None if line is None else board[line[0] - 1]


def winning_line(board: Board) -> tuple[int, int, int] | None:
    """The completed line as cells 1..9, or None."""
    for a, b, c in LINES:
        if board[a] in (CIRCLE, CROSS) and board[a] == board[b] == board[c]:
            return (a + 1, b + 1, c + 1)
    return None


def game_over(board: Board) -> bool:
    """True when a mark has three in a row or the board is full."""
    return winner(board) is not None or EMPTY not in board


def other(mark: str) -> str:
    """The opponent's mark."""
    return CROSS if mark == CIRCLE else CIRCLE


@lru_cache(maxsize=None)
def _value(board: Board, to_move: str, me: str) -> int:
    """Minimax value of ``board`` for ``me`` with ``to_move`` to play: >0 win, 0 draw, <0 loss.

    A win scores ``10 + empties`` (empty cells left), so a quicker win scores higher and a later
    loss less badly.
    """
    w = winner(board)
    empties = board.count(EMPTY)
    if w is not None:
        return (10 + empties) if w == me else -(10 + empties)
    if empties == 0:
        return 0
    values = (_value(play(board, c, to_move), other(to_move), me) for c in free_cells(board))
    return max(values) if to_move == me else min(values)


def move_values(board: Board, mark: str) -> dict[int, int]:
    """Minimax value of every free cell for the player of ``mark`` to move now."""
    board = check_board(board)
    return {c: _value(play(board, c, mark), other(mark), mark) for c in free_cells(board)}


def best_moves(board: Board, mark: str) -> list[int]:
    """All optimal cells for ``mark`` (equal minimax value), in :data:`PREFERENCE` order.

    Raises
    ------
    InputError
        The game is already over.
    """
    board = check_board(board)
    if game_over(board):
        raise InputError("the game is over: there is no move to make")
    values = move_values(board, mark)
    top = max(values.values())
    return [c for c in PREFERENCE if values.get(c) == top]


def best_move(board: Board, mark: str) -> int:
    """The optimal cell for ``mark``, ties broken by :data:`PREFERENCE` (centre first)."""
    return best_moves(board, mark)[0]


def render(board: Board) -> str:
    """The board as text, cell numbers shown in empty cells, e.g.::

         O | 2 | X
        ---+---+---
         4 | O | 6
        ---+---+---
         7 | 8 | X

    Rows are as the robot sees the grid: the first row is the far one.
    """
    cells = [m if m else str(i + 1) for i, m in enumerate(board)]
    rows = [" " + " | ".join(cells[r * 3 : r * 3 + 3]) for r in range(3)]
    return "\n---+---+---\n".join(rows)
