"""One error root for everything a user can get wrong, with exit codes the CLI maps to.

``HilaError`` carries an optional source position (file, line, column) and source line; ``str()``
renders ``FILE:LINE:COL: error: MESSAGE`` followed by the source line and a caret when they are
known.  Subclasses say which stage raised it and which exit status the CLI returns:

- exit 2 (bad input): :class:`InputError` (also a ``ValueError``), :class:`HilaSyntaxError`,
  :class:`CheckError`
- exit 1 (a run that failed): :class:`HilaRuntimeError` and its subclasses
  :class:`ConstraintError` (contradicted constraints), :class:`UnreachableError`,
  :class:`UnknownNameError` (a program asks a world for a question or event it does not have)
  and :class:`StepLimitError` (more steps than ``--max-steps``)
- exit 130: :class:`Interrupted` (Ctrl-C during a run)
- exit 3 (an internal error): anything else -- a ``KeyError``, ``TypeError``, ... raised by hila,
  a plug-in or OSILA is a bug, not a user error.  The CLI says so, names where it was raised and
  where to report it; ``hila --debug ...`` shows the traceback (:func:`internal_error_message`).
"""

from __future__ import annotations

import difflib
import traceback

EXIT_OK = 0
EXIT_RUN_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 3
#: stopped by Ctrl-C (SIGINT), as shells report it: 128 + 2
EXIT_INTERRUPTED = 130

#: widest source line shown under an error; a longer one is clipped around the column
SHOWN_WIDTH = 100
#: longest line of a message; a longer one (a giant name echoed back) is clipped in the middle.
#: Generous: a message that lists what it tried (constraint pairs) is long on purpose.
MESSAGE_WIDTH = 2000

#: where a user reports an internal error of hila itself
REPORT_TO = "the hila maintainers (the issue tracker of the project hila-lang)"


class HilaError(Exception):
    """Root of every error hila reports to a user."""

    exit_code = EXIT_BAD_INPUT

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        source_line: str | None = None,
        hint: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.column = column
        self.source_line = source_line
        self.hint = hint

    def location(self) -> str:
        """``FILE:LINE:COL`` (as much of it as is known), or ``""``."""
        parts = [str(p) for p in (self.file, self.line, self.column) if p is not None]
        return ":".join(parts)

    def __str__(self) -> str:
        loc = printable(self.location())
        message = printable(self.message)
        head = f"{loc}: error: {message}" if loc else f"error: {message}"
        lines = [head]
        if self.source_line is not None:
            shown, caret = show_source(self.source_line, self.column)
            lines.append(f"    {shown}")
            if caret is not None:
                lines.append("    " + " " * caret + "^")
        if self.hint:
            lines.append(f"hint: {printable(self.hint)}")
        return "\n".join(lines)


def _escape(ch: str) -> str:
    """One character as a terminal may show it: a tab as a space, a control or format character
    (ESC, NUL, a right-to-left override, a byte-order mark) as its escape, e.g. ``\\x1b``."""
    if ch == "\t":
        return " "
    if ch.isprintable() or ch == " ":
        return ch
    return ch.encode("unicode_escape").decode("ascii")


def printable(text: str, width: int = MESSAGE_WIDTH) -> str:
    """``text`` safe to print: control characters escaped line by line, lines longer than ``width``
    clipped in the middle (``...``).  An error message is an interface: it never sends raw
    escape sequences to a terminal, and never echoes a megabyte back."""
    out = []
    for line in str(text).split("\n"):
        line = "".join(map(_escape, line))
        if len(line) > width:
            half = (width - 5) // 2
            line = f"{line[:half]} ... {line[-half:]}"
        out.append(line)
    return "\n".join(out)


def show_source(line: str, column: int | None, width: int = SHOWN_WIDTH) -> tuple[str, int | None]:
    """A source line as shown under an error, and the caret's offset in it (None: no caret).

    Control characters are escaped (:func:`_escape`); a line wider than ``width`` is clipped to
    a window around ``column`` with ``...`` where text was cut, and the caret moves with it.
    """
    pieces = [_escape(ch) for ch in line.rstrip("\r\n")]
    starts = [0]
    for p in pieces:
        starts.append(starts[-1] + len(p))
    total = starts[-1]
    caret = None
    if column is not None and column >= 1:
        caret = starts[min(column - 1, len(pieces))]
    if total <= width:
        return "".join(pieces), caret
    anchor = caret if caret is not None else 0
    lo = max(0, min(anchor - width // 2, total - width))
    first = next(i for i, s in enumerate(starts) if s >= lo)  # cut on whole characters only
    last = next((i for i, s in enumerate(starts) if s > starts[first] + width), len(starts)) - 1
    head = "..." if first > 0 else ""
    tail = "..." if last < len(pieces) else ""
    shown = head + "".join(pieces[first:last]) + tail
    return shown, None if caret is None else len(head) + caret - starts[first]


class InputError(HilaError, ValueError):
    """Bad input data: wrong array shapes, NaN, a broken template or task file."""


class HilaSyntaxError(HilaError):
    """A .hila program that does not parse."""


class CheckError(HilaError):
    """A .hila program that parses but is wrong (unknown names, arity, unbound ICPs, ...)."""


class HilaRuntimeError(HilaError):
    """A run that failed; ``state`` names the FSM state when there is one."""

    exit_code = EXIT_RUN_FAILED

    def __init__(self, message: str, *, state: str | None = None, **kwargs) -> None:
        super().__init__(message, **kwargs)
        self.state = state

    def __str__(self) -> str:
        text = super().__str__()
        if self.state:
            first, sep, rest = text.partition("\n")
            text = f"{first} (in state {self.state})" + (sep + rest if sep else "")
        return text


class ConstraintError(HilaRuntimeError):
    """OSILA could not make the route conform to its forced waypoints and obstacles."""


class UnreachableError(HilaRuntimeError):
    """The robot cannot reach a target point."""


class StepLimitError(HilaRuntimeError):
    """A run took more steps than its limit (``--max-steps``): a loop that never ends."""


class Interrupted(HilaRuntimeError):
    """A run stopped by Ctrl-C (SIGINT) between or inside states; exit status 130.  The REPL
    reports it and goes on: the world, the simulator and the hand are as the interrupt left
    them."""

    exit_code = EXIT_INTERRUPTED


class UnknownNameError(HilaRuntimeError):
    """A world (or a plug-in) was asked for a name it does not have: ``ask NAME`` or ``wait NAME``.

    Parameters
    ----------
    kind : str
        ``"question"`` or ``"event"``.
    name : str
    known : iterable of str
        The names it does have (for the list and the "did you mean").
    owner : str
        Who was asked, e.g. ``"world tictactoe"``.
    """

    def __init__(self, kind: str, name: str, known=(), owner: str = "the world", **kwargs) -> None:
        known = sorted(known)
        close = difflib.get_close_matches(name, known, n=1)
        hint = f"did you mean '{close[0]}'?" if close else (f"its {kind}s: {', '.join(known)}" if known else None)
        super().__init__(f"{owner} has no {kind} '{name}'", hint=kwargs.pop("hint", hint), **kwargs)
        self.kind, self.name, self.known = kind, name, known


def did_you_mean(name: str, choices) -> str | None:
    """``"did you mean 'x'?"`` for the choice closest to ``name`` (difflib, cutoff 0.6), or None:
    the one "did you mean" of every message."""
    close = difflib.get_close_matches(name, sorted(set(choices)), n=1, cutoff=0.6)
    return f"did you mean '{close[0]}'?" if close else None


def internal_error_message(exc: BaseException) -> str:
    """What the CLI prints for an exception that is not a :class:`HilaError`: that it is a bug,
    where it was raised (the innermost frame) and whom to report it to -- hila's maintainers, or
    a plug-in's authors when the innermost frame of the package belongs to another distribution.
    """
    frames = traceback.extract_tb(exc.__traceback__)
    where = ""
    module = ""
    if frames:
        last = frames[-1]
        where = f"\n  raised in {last.filename}:{last.lineno}, in {last.name}"
        tb = exc.__traceback__
        while tb.tb_next is not None:
            tb = tb.tb_next
        module = tb.tb_frame.f_globals.get("__name__", "")
    owner = _distribution(module)
    if owner is None or owner.lower().replace("_", "-") == "hila-lang":
        blame = ("This is a bug in hila, not a mistake in your program or data.\n"
                 f"Please report it to {REPORT_TO} with the command you ran and the output of "
                 "the same command with 'hila --debug'.")
    else:
        blame = (f"This is a bug in the plug-in module {module!r} (distribution {owner!r}), not in your "
                 f"program or data.\nPlease report it to that plug-in's authors with the command you ran "
                 "and the output of the same command with 'hila --debug'.")
    kind = type(exc).__name__
    text = printable(str(exc).splitlines()[0]) if str(exc) else ""
    return f"internal error: {kind}{': ' + text if text else ''}{where}\n{blame}"


def _distribution(module: str) -> str | None:
    """The installed distribution that provides the top-level package of ``module``, or None."""
    if not module:
        return None
    top = module.split(".")[0]
    if top == "hila_lang":
        return "hila-lang"
    try:
        # lazy: only this branch needs it
        from importlib.metadata import packages_distributions

        dists = packages_distributions().get(top)
    except Exception:  # noqa: BLE001 - best effort: the message must still be printed
        return None
    return dists[0] if dists else None
