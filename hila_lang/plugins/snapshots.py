"""A :class:`~hila_lang.plugins.protocols.Snapshots` capability for state held in attributes.

Most worlds and simple back ends are what a few attributes hold: a board, a list of moves, a
random generator.  :class:`AttributeSnapshots` saves them by deep copy, except lists that only
ever grow (``append_only``: a log, the moves so far), which are saved by their length and cut
back on restore, so a long session does not copy its whole history at every step.
"""

from __future__ import annotations

import copy
from typing import Any


def _get(owner, dotted: str):
    for part in dotted.split("."):
        owner = getattr(owner, part)
    return owner


def _set(owner, dotted: str, value) -> None:
    head, _, last = dotted.rpartition(".")
    setattr(_get(owner, head) if head else owner, last, value)


def _has(owner, dotted: str) -> bool:
    try:
        _get(owner, dotted)
    except AttributeError:
        return False
    return True


class AttributeSnapshots:
    """Snapshots of ``owner``'s attributes ``copied`` (deep copies; dotted names reach into parts,
    e.g. ``"opponent._rng"``; a name the owner does not have is skipped) and ``append_only``
    (lists that only grow: saved as their length, cut back to it on restore -- so a token is
    restored only after those saved later are discarded, as the protocol says)."""

    def __init__(self, owner, copied=(), append_only=()) -> None:
        self.owner, self.copied, self.append_only = owner, tuple(copied), tuple(append_only)

    def save(self) -> dict[str, Any]:
        o = self.owner
        return {"copied": {n: copy.deepcopy(_get(o, n)) for n in self.copied if _has(o, n)},
                "lengths": {n: len(_get(o, n)) for n in self.append_only}}

    def restore(self, saved: dict[str, Any]) -> None:
        for name, value in saved["copied"].items():
            _set(self.owner, name, copy.deepcopy(value))  # the token stays usable
        for name, length in saved["lengths"].items():
            del _get(self.owner, name)[length:]

    def discard(self, saved: dict[str, Any]) -> None:
        pass
