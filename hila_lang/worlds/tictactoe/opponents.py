"""The robot's opponents: two seeded built-in players and a person typing at a prompt.

Every opponent plays crosses (``"X"``) and answers :meth:`Opponent.choose` with a free cell 1..9.

- ``random``: a uniformly random free cell (seeded);
- ``minimax``: an optimal player; among equally good cells it picks one at random (seeded), so
  different seeds give different optimal games;
- ``human``: asks for a cell number on a text stream; bad input (not a number, out of 1..9, a
  taken cell) is reported and asked again; end of input is a clear error.
"""

from __future__ import annotations

import difflib
import random
import sys
from typing import Protocol, TextIO

from ...core.errors import HilaRuntimeError, InputError
from .rules import best_moves, Board, CROSS, free_cells, render

#: names accepted by ``--opponent``
NAMES = ("random", "minimax", "human")
#: the default opponent (built in, so ``hila exec programs/game.hila`` runs unattended)
DEFAULT = "minimax"


class Opponent(Protocol):
    """Chooses the opponent's next cell."""

    name: str

    def choose(self, board: Board) -> int:
        """A free cell 1..9 of ``board`` (crosses are the opponent's marks)."""
        ...


class RandomOpponent:
    """Plays a uniformly random free cell; ``seed`` makes the game reproducible."""

    name = "random"

    def __init__(self, seed: int = 0) -> None:
        self._rng = random.Random(seed)

    def choose(self, board: Board) -> int:
        return self._rng.choice(free_cells(board))


class MinimaxOpponent:
    """Plays optimally (it never loses either); ties among optimal cells are broken at random."""

    name = "minimax"

    def __init__(self, seed: int = 0) -> None:
        self._rng = random.Random(seed)

    def choose(self, board: Board) -> int:
        return self._rng.choice(best_moves(board, CROSS))


class HumanOpponent:
    """A person typing a cell number (1..9) at a prompt.

    Parameters
    ----------
    stdin, stdout : text streams
        Where the prompt reads and writes (the process's own by default).
    """

    name = "human"

    def __init__(self, stdin: TextIO | None = None, stdout: TextIO | None = None) -> None:
        self._in = stdin if stdin is not None else sys.stdin
        self._out = stdout if stdout is not None else sys.stdout

    def choose(self, board: Board) -> int:
        free = free_cells(board)
        while True:
            self._out.write(f"your move, a free cell {_ranges(free)} (q to quit): ")
            self._out.flush()
            line = self._in.readline()
            if line == "":
                self._out.write("\n")
                raise InputError(
                    "no opponent move: the input ended while waiting for a cell number",
                    hint="type a cell 1..9 at the prompt, or use --opponent random|minimax",
                )
            text = line.strip()
            if not getattr(self._in, "isatty", lambda: False)():
                self._out.write(text + "\n")  # echo piped input, so a transcript reads like a session
            if text.lower() in ("q", "quit", "exit"):
                raise HilaRuntimeError("the opponent quit the game")
            problem = _problem(text, board)
            if problem is None:
                return int(text)
            self._out.write(f"{problem}\n{render(board)}\n")


def _problem(text: str, board: Board) -> str | None:
    """Why ``text`` is not a playable cell on ``board``, or None when it is."""
    if not text:
        return "please type a cell number 1..9"
    if not text.isdigit():
        return f"{text!r} is not a cell number: type 1..9 (1 = far-left, 9 = near-right)"
    cell = int(text)
    if not 1 <= cell <= 9:
        return f"there is no cell {cell}: cells are 1..9"
    if board[cell - 1]:
        return f"cell {cell} is taken (it holds {board[cell - 1]})"
    return None


def _ranges(cells: list[int]) -> str:
    return "(" + " ".join(str(c) for c in cells) + ")"


def make_opponent(name: str | None, seed: int = 0, stdin: TextIO | None = None,
                  stdout: TextIO | None = None) -> Opponent:
    """The opponent called ``name`` (None = :data:`DEFAULT`).

    Raises
    ------
    InputError
        An unknown name; the message lists the known ones.
    """
    name = DEFAULT if name is None else str(name).strip().lower()
    if name == "random":
        return RandomOpponent(seed)
    if name == "minimax":
        return MinimaxOpponent(seed)
    if name == "human":
        return HumanOpponent(stdin, stdout)

    close = difflib.get_close_matches(name, NAMES, n=1)
    hint = f"did you mean {close[0]!r}?" if close else None
    raise InputError(f"unknown opponent {name!r}; expected one of: {', '.join(NAMES)}", hint=hint)
