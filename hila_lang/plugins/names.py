"""A world's names, declared once: its points, questions and events, each with its arguments,
its one-line doc and the world method that answers it.

A world plug-in lists them on its :class:`~hila_lang.plugins.registry.WorldInfo` (settings are
:class:`~hila_lang.plugins.settings.Setting` s, declared the same way).  Everything reads that one
table: the running world answers ``ask NAME(args)`` and ``wait NAME`` through
:meth:`Names.answer` (unknown name, wrong number of arguments: one message each), ``hila check``
(:mod:`hila_lang.language.worldcheck`) checks a program's names and argument counts against it,
``hila show world NAME`` prints it and the language server reads it for hovers and completion.

A :class:`Names` is also a read-only mapping name -> doc, so code that wants only the docs (a
"did you mean", a completion list) reads it like a dict, and a third-party plug-in may still
declare ``questions={"ready": "doc"}``: the dict becomes a table without answer methods.
Declaring names imports nothing heavy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Iterator, Mapping

from ..core.errors import InputError, UnknownNameError


@dataclass(frozen=True)
class Name:
    """One declared name.

    Attributes
    ----------
    name : str
        As a program writes it: ``best_move``, ``free``, ``board.cellN.tl|tr|br|bl`` (a point
        pattern: ``N`` a number, ``a|b`` alternatives).
    doc : str
        One line: what it is or answers.
    args : tuple of str
        The arguments' names (``("N",)`` for ``ask free(N)``); empty for none.
    answer : str or None
        The name of the world's method that answers it (called with the arguments); None for a
        point, or a name only declared (a plug-in that answers it itself).
    """

    name: str
    doc: str
    args: tuple[str, ...] = ()
    answer: str | None = None

    @property
    def signature(self) -> str:
        """``free(N)``, or the bare name without arguments."""
        return f"{self.name}({', '.join(self.args)})" if self.args else self.name


class Names(Mapping[str, str]):
    """The declared names of one kind (``"point"``, ``"question"``, ``"event"``), in order.

    As a mapping: name -> doc.  :meth:`entry` gives the whole :class:`Name`.
    """

    def __init__(self, kind: str, entries: Iterable[Name] = ()) -> None:
        self.kind = kind
        self.entries: tuple[Name, ...] = tuple(entries)
        self._by = {e.name: e for e in self.entries}
        if len(self._by) != len(self.entries):
            raise TypeError(f"{kind} names declared twice: {[e.name for e in self.entries]}")

    @classmethod
    def of(cls, kind: str, given: "Names | Mapping[str, str] | Iterable[Name] | None") -> "Names":
        """A table from a table, a mapping name -> doc, or Names; ``None``: empty."""
        if isinstance(given, Names):
            return given
        if given is None:
            return cls(kind)
        if isinstance(given, Mapping):
            return cls(kind, [Name(str(k), str(v)) for k, v in given.items()])
        return cls(kind, given)

    # -- the mapping name -> doc -------------------------------------------------------------
    def __getitem__(self, name: str) -> str:
        return self._by[name].doc

    def __iter__(self) -> Iterator[str]:
        return iter(self._by)

    def __len__(self) -> int:
        return len(self._by)

    def __repr__(self) -> str:
        return f"Names({self.kind!r}, {[e.signature for e in self.entries]})"

    def entry(self, name: str) -> Name | None:
        return self._by.get(name)

    def arities(self) -> dict[tuple[str, str], int]:
        """(kind, name) -> number of arguments, for the names the world answers itself (a name
        declared only by its doc says nothing about its arguments): what ``hila check`` checks
        a call by."""
        return {(self.kind, e.name): len(e.args) for e in self.entries if e.answer is not None}

    # -- the running world ----------------------------------------------------------------------
    def answer(self, world: Any, name: str, args: tuple, owner: str) -> Any:
        """Call the method of ``world`` that answers ``name`` with ``args``.

        A name not declared (or declared without an answer) is an
        :class:`~hila_lang.core.errors.UnknownNameError` with "did you mean"; a wrong number of
        arguments an :class:`~hila_lang.core.errors.InputError` saying how many it takes.
        """
        entry = self._by.get(name)
        if entry is None or entry.answer is None:
            raise UnknownNameError(self.kind, name, [e.name for e in self.entries if e.answer], owner=owner)
        if len(args) != len(entry.args):
            raise InputError(f"{self.kind} '{name}' takes {_count(len(entry.args))} ({entry.signature}), "
                             f"got {len(args)}")
        return getattr(world, entry.answer)(*args)


def _count(n: int) -> str:
    return "no arguments" if n == 0 else "one argument" if n == 1 else f"{n} arguments"
