"""One error root for everything a user can get wrong, with exit codes the CLI maps to.

``HilaError`` carries an optional source position (file, line, column) and source line; ``str()``
renders ``FILE:LINE:COL: error: MESSAGE`` followed by the source line and a caret when they are
known.  Subclasses say which stage raised it and which exit status the CLI returns:

- exit 2 (bad input): :class:`InputError` (also a ``ValueError``), :class:`HilaSyntaxError`,
  :class:`CheckError`
- exit 1 (a run that failed): :class:`HilaRuntimeError` and its subclasses
  :class:`ConstraintError` (contradicted constraints) and :class:`UnreachableError`
"""

from __future__ import annotations

EXIT_OK = 0
EXIT_RUN_FAILED = 1
EXIT_BAD_INPUT = 2


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
        loc = self.location()
        head = f"{loc}: error: {self.message}" if loc else f"error: {self.message}"
        lines = [head]
        if self.source_line is not None:
            src = self.source_line.rstrip("\n").expandtabs(1)
            lines.append(f"    {src}")
            if self.column is not None and self.column >= 1:
                lines.append("    " + " " * (self.column - 1) + "^")
        if self.hint:
            lines.append(f"hint: {self.hint}")
        return "\n".join(lines)


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
