"""Run plug-ins: which world and which back end a program runs with, and the options they get.

Worlds and back ends are named by strings and imported lazily, so ``hila --help`` stays instant
and the language core never imports PyBullet or the game.

Protocol (see :mod:`hila_lang.interfaces`):

- ``make_world(options: RunOptions) -> World``.  Optional extras the runner uses when present:
  ``world.default_backend`` (a name in :data:`BACKENDS`), ``world.attach(backend)`` (called once
  the back end exists), ``world.finish(trace) -> dict`` (called after the run with the list of
  :class:`~hila_lang.language.interpreter.TraceEntry`; prints the result, writes outputs).
- ``make_backend(world, options: RunOptions) -> Backend``; both back ends also offer
  ``reset_hand(point)`` (put the hand at ``point`` without drawing).

The interpreter calls ``world.notify("state_done", state=NAME, path=PLANNED, executed=TRACE,
kind="run", pen_down=BOOL, icps={NAME: POINT})`` after each run state, ``world.notify("program_done")`` when the FSM
reaches its end, and ``world.query`` / ``world.wait`` for ``ask`` and ``wait``.
"""

from __future__ import annotations

import difflib
import importlib
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from ..errors import InputError

#: world name (as written ``world NAME`` in a program) -> "module:factory"
WORLDS = {
    "scripted": "hila_lang.language.scripted:make_world",
    "tictactoe": "hila_lang.games.world:make_world",
}

#: back-end name (``--backend NAME``) -> "module:factory"
BACKENDS = {
    "dry": "hila_lang.language.dry:make_backend",
    "pybullet": "hila_lang.robot.backend:make_backend",
}

DEFAULT_WORLD = "scripted"
DEFAULT_BACKEND = "dry"


@dataclass
class RunOptions:
    """Everything ``hila exec`` / ``hila repl`` pass to worlds and back ends.

    Attributes
    ----------
    seed : int
        Seed for every random choice (scene placement, opponents).
    out : Path or None
        Output folder for files a world writes (None: the world decides).
    opponent : str or None
        Opponent name for game worlds (``random``, ``minimax``, ``human``).
    gui : bool
        Open a GUI window (PyBullet) instead of running headless.
    settings : dict[str, str]
        Free ``--set key=value`` pairs, read by whichever plug-in knows the key.
    stdin, stdout : text streams
        A human opponent and the REPL read the same ``stdin``, so piped input drives both.
    """

    seed: int = 0
    out: Path | None = None
    opponent: str | None = None
    gui: bool = False
    settings: dict[str, str] = field(default_factory=dict)
    stdin: TextIO = field(default_factory=lambda: sys.stdin)
    stdout: TextIO = field(default_factory=lambda: sys.stdout)


def parse_settings(pairs: list[str] | None) -> dict[str, str]:
    """``["a=1", "b=x"]`` -> ``{"a": "1", "b": "x"}``; a pair without ``=`` is an InputError."""
    settings: dict[str, str] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(f"expected --set KEY=VALUE, got {pair!r}")
        settings[key.strip()] = value.strip()
    return settings


def _resolve(kind: str, name: str, table: dict[str, str]):
    if name not in table:
        close = difflib.get_close_matches(name, table, n=1)
        hint = f"did you mean {close[0]!r}?" if close else None
        raise InputError(f"unknown {kind} {name!r}; known: {', '.join(sorted(table))}", hint=hint)
    module_name, _, attr = table[name].partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name and module_name.startswith(exc.name):
            raise InputError(f"{kind} {name!r} is not available in this installation ({module_name} is missing)") from None
        raise
    return getattr(module, attr)


def world_factory(name: str):
    """The ``make_world`` callable registered as ``name`` (InputError with "did you mean")."""
    return _resolve("world", name, WORLDS)


def backend_factory(name: str):
    """The ``make_backend`` callable registered as ``name`` (InputError with "did you mean")."""
    return _resolve("back end", name, BACKENDS)


def make_world(name: str, options: RunOptions) -> Any:
    """Build the world ``name`` for a run; a ``--set`` key it does not know is an InputError."""
    world = world_factory(name)(options)
    known = tuple(world.SETTINGS)
    for key in options.settings:
        if not key.startswith("osila.") and key not in known:
            close = difflib.get_close_matches(key, known, n=1)
            raise InputError(
                f"unknown setting {key!r} for world {name!r}; known: "
                + ", ".join([*known, "osila.OPTION"]),
                hint=f"did you mean {close[0]!r}?" if close else None)
    return world


def make_backend(world: Any, options: RunOptions, name: str | None = None) -> Any:
    """Build the back end: ``name`` if given, else ``world.default_backend``, else ``"dry"``.

    Calls ``world.attach(backend)`` when the world has it.
    """
    kind = name or getattr(world, "default_backend", None) or DEFAULT_BACKEND
    backend = backend_factory(kind)(world, options)
    attach = getattr(world, "attach", None)
    if callable(attach):
        attach(backend)
    return backend
