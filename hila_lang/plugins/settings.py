"""``--set KEY=VALUE`` settings that plug-ins declare: :class:`Setting` and ready-made parsers.

A plug-in lists its settings on its :class:`~hila_lang.plugins.registry.WorldInfo` or
:class:`~hila_lang.plugins.registry.BackendInfo`; each has a one-line doc, a parser from the text
the user typed to a value (raising ``ValueError`` with what it expected) and a default.  The
runner parses every setting before anything is built, so a bad value is refused (exit status 2)
before a world, a simulator or a game starts.  Parsers are plain Python: declaring settings
imports nothing heavy.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from typing import Any, Callable, Iterable

from ..core.errors import InputError


@dataclass(frozen=True)
class Setting:
    """One ``--set NAME=VALUE`` a plug-in understands.

    Attributes
    ----------
    name : str
    doc : str
        One line, shown by ``--help`` and editors.
    parse : callable
        Text -> value; raises ``ValueError`` saying what it expected.
    default : Any
        The value when the user gives none (not parsed).
    metavar : str
        How the value is shown in help (``robot|opponent``, ``X,Y,Z``).
    flag : str or None
        A command-line alias, e.g. ``--opponent`` for ``--set opponent=...``.
    """

    name: str
    doc: str
    parse: Callable[[str], Any] = str
    default: Any = None
    metavar: str = "VALUE"
    flag: str | None = None

    def help(self) -> str:
        """``name=METAVAR  doc (default: ...)``: one line for ``--help``."""
        default = "" if self.default is None else f" (default: {show_value(self.default)})"
        return f"{self.name}={self.metavar}  {self.doc}{default}"


def show_value(value: Any) -> str:
    """A setting's value as a person types it after ``--set KEY=`` (yes/no, comma lists)."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (tuple, list)):
        return ",".join(show_value(v) for v in value)
    return str(value)


def parse_settings(declared: Iterable[Setting], given: dict[str, str], owner: str) -> dict[str, Any]:
    """Every declared setting's value: the parsed text where given, else its default.

    ``given`` must hold only declared names (the runner splits ``--set`` among plug-ins first).
    A value its parser refuses is an :class:`InputError` naming the setting and the owner.
    """
    out: dict[str, Any] = {}
    for s in declared:
        if s.name not in given:
            out[s.name] = s.default
            continue
        text = given[s.name]
        try:
            out[s.name] = s.parse(text)
        except (ValueError, TypeError) as exc:
            raise InputError(f"bad value for --set {s.name}={text} ({owner}): {exc}",
                             hint=f"{s.name}={s.metavar}: {s.doc}") from None
    return out


# --------------------------------------------------------------------------- parsers


def choice(*values: str) -> Callable[[str], str]:
    """One of ``values`` (case-insensitive); a near miss is suggested."""

    def parse(text: str) -> str:
        t = text.strip().lower()
        if t in values:
            return t
        close = difflib.get_close_matches(t, values, n=1)
        raise ValueError(f"expected {'|'.join(values)}, got {text!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))

    parse.__name__ = "|".join(values)
    return parse


_BOOLEANS = {"yes": True, "true": True, "1": True, "on": True, "no": False, "false": False, "0": False, "off": False}


def boolean(text: str) -> bool:
    """yes/no, true/false, on/off, 1/0."""
    t = text.strip().lower()
    if t not in _BOOLEANS:
        raise ValueError(f"expected yes or no, got {text!r}")
    return _BOOLEANS[t]


def number(minimum: float | None = None, maximum: float | None = None) -> Callable[[str], float]:
    """A finite number within [minimum, maximum]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise ValueError(f"expected a number, got {text!r}") from None
        if value != value or value in (float("inf"), float("-inf")):
            raise ValueError(f"expected a finite number, got {text!r}")
        if (minimum is not None and value < minimum) or (maximum is not None and value > maximum):
            raise ValueError(f"expected a number in [{minimum}, {maximum}], got {value:g}")
        return value

    return parse


def point(text: str) -> tuple[float, float, float]:
    """``X,Y,Z`` (three numbers, metres; parentheses allowed)."""
    parts = text.replace("(", "").replace(")", "").split(",")
    try:
        values = tuple(float(v) for v in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or any(v != v or v in (float("inf"), float("-inf")) for v in values):
        raise ValueError(f"expected X,Y,Z (three finite numbers, metres), got {text!r}")
    return values


def text(pattern: str | None = None, what: str = "text") -> Callable[[str], str]:
    """Any text, or text matching the regular expression ``pattern`` (whole)."""
    def parse(value: str) -> str:
        if pattern is not None and not re.fullmatch(pattern, value):
            raise ValueError(f"expected {what}, got {value!r}")
        return value

    return parse
