"""What ``hila exec`` / ``hila repl`` pass to every world and back end."""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO


@dataclass
class RunOptions:
    """Options shared by all plug-ins (their own settings come separately, parsed).

    Attributes
    ----------
    seed : int
        Seed for every random choice (scene placement, opponents).
    out : Path or None
        Output folder for files a world writes (None: the world decides).
    gui : bool
        Open a GUI window (PyBullet) instead of running headless.
    settings : dict[str, str]
        ``--set key=value`` pairs as typed; the runner splits them among OSILA (``osila.*``),
        the world and the back end, and parses each with the owner's declaration.
    stdin, stdout : text streams
        A human opponent and the REPL read the same ``stdin``, so piped input drives both.
    """

    seed: int = 0
    out: Path | None = None
    gui: bool = False
    settings: dict[str, str] = field(default_factory=dict)
    stdin: TextIO = field(default_factory=lambda: sys.stdin)
    stdout: TextIO = field(default_factory=lambda: sys.stdout)


def parse_pairs(pairs: list[str] | None) -> dict[str, str]:
    """``["a=1", "b=x"]`` -> ``{"a": "1", "b": "x"}``; a pair without ``=`` is an InputError."""
    from ..errors import InputError

    settings: dict[str, str] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(f"expected --set KEY=VALUE, got {pair!r}")
        settings[key.strip()] = value.strip()
    return settings
