"""Reading program text and reporting its syntax errors in words a student can act on.

The grammar is data (``grammar/hila.lark``), loaded once (LALR, positions kept) by
:func:`hila_lang.language.transformer.grammar` for the
:class:`~hila_lang.language.environment.Environment`.  :func:`syntax_error` turns every lark
failure into a :class:`HilaSyntaxError` that says
what was found, what was expected, names a common slip when it recognises one
(``match_examples``) and, at the end of the file, the innermost block left open.
"""

from __future__ import annotations

import functools
import os

from ..core.errors import HilaSyntaxError
from ..core.fileio import read_bytes

#: common slips -> small programs that make the parser fail the same way (lark match_examples)
COMMON_SLIPS: dict[str, list[str]] = {
    "a run needs its ICP bindings in parentheses: run TEMPLATE.TAG(icp = point, ...)": [
        "main { run a.b }",
        "main { run a.b x = 1 }",
        "task t() { run a.b }",
    ],
    "bind an ICP with '=': run TEMPLATE.TAG(icp = point)": [
        "main { run a.b(x: 1) }",
        "main { run a.b(x 1) }",
        "main { run a.b(x == 1) }",
    ],
    "'=' binds a name; compare with '=='": [
        "main { if x = 1 { } }",
        "main { while x = 1 { } }",
        "main { until x = 1 { } }",
    ],
    "a block needs braces: { ... }": [
        "main { if true run a.b() }",
        "main { while true run a.b() }",
        "main { repeat 2 run a.b() }",
        "task t() run a.b()",
        "main run a.b()",
    ],
    "write 'else if', not 'elif'": ["main { if true { } elif true { } }"],
    "statements belong inside 'main { ... }' or a 'task NAME(params) { ... }'": [
        "run a.b()",
        "let x = 1",
        "wait e",
        "if true { }",
        "repeat 2 { }",
    ],
    "a task definition needs a parameter list: task NAME(params) { ... }": ["task t { }"],
    "separate arguments with ','": ["main { f(1 2) }", "main { run a.b(x = 1 y = 2) }"],
    "'let' needs a name and a value: let NAME = value": ["main { let = 1 }", "main { let x }", "main { let x 1 }"],
}

_FRIENDLY = {
    "NAME": "a name",
    "NUMBER": "a number",
    "STRING": "a string",
    "PEN_STATE": "'up' or 'down'",
    "COMPARE": "a comparison",
    "ADD_OP": "'+' or '-'",
    "MUL_OP": "'*' or '/'",
    "$END": "the end of the file",
}

_OPENERS = ("task", "main", "if", "else", "while", "until", "repeat")


def read_source(path: str | os.PathLike) -> str:
    """Read a program file; OS failures are InputError, bad UTF-8 a syntax error at its line and column."""
    return decode_source(read_bytes(path, "program"), str(path))


def decode_source(data: bytes, file: str = "<program>") -> str:
    """UTF-8 bytes -> text; a bad byte is a :class:`HilaSyntaxError` with line and column.
    A byte-order mark at the start (editors on Windows write one) is dropped."""
    try:
        text = data.decode("utf-8").removeprefix("\ufeff")
        if "\r" in text:  # CR-only line ends (old Mac editors) made the first comment swallow the file
            text = text.replace("\r\n", "\n").replace("\r", "\n")
        return text
    except UnicodeDecodeError as exc:
        start = data.rfind(b"\n", 0, exc.start) + 1
        line = data.count(b"\n", 0, exc.start) + 1
        column = len(data[start : exc.start].decode("utf-8", "replace")) + 1
        end = data.find(b"\n", exc.start)
        shown = data[start : end if end >= 0 else len(data)].decode("utf-8", "replace")
        raise HilaSyntaxError(
            f"the program is not UTF-8 text (byte 0x{data[exc.start]:02x})",
            file=file, line=line, column=column, source_line=shown,
            hint="save the file as UTF-8",
        ) from None


def source_line(text: str, line: int) -> str | None:
    """Line ``line`` (1-based) of ``text``, or None."""
    lines = text.splitlines()
    return lines[line - 1] if 1 <= line <= len(lines) else None


def _describe(term: str, lark) -> str:
    if term in _FRIENDLY:
        return _FRIENDLY[term]
    try:
        pattern = lark.get_terminal(term).pattern
    except KeyError:
        return term
    if type(pattern).__name__ == "PatternStr":
        return f"'{pattern.value}'"
    return term.lower()


def _expected(names, lark) -> str:
    """Readable list of what the parser would have accepted ("" when it is too long to help)."""
    shown = sorted({_describe(n, lark) for n in names})
    if len(shown) > 7:
        return ""
    return shown[0] if len(shown) == 1 else ", ".join(shown[:-1]) + " or " + shown[-1]


def _with_expected(message: str, names, lark) -> str:
    expected = _expected(names, lark)
    return f"{message}; expected {expected}" if expected else message


def _unclosed_block(text: str):
    """(keyword, line, column) of the innermost '{' never closed, or None."""
    stack: list[tuple[str, int, int]] = []
    last_word: tuple[str, int, int] | None = None
    stmt_word: tuple[str, int, int] | None = None
    line, col, i, n = 1, 1, 0, len(text)
    while i < n:
        ch = text[i]
        if ch == "#":
            while i < n and text[i] != "\n":
                i += 1
            continue
        if ch == '"':
            j = text.find('"', i + 1)
            nl = text.find("\n", i + 1)
            j = j if j >= 0 and (nl < 0 or j < nl) else (nl if nl >= 0 else n) - 1
            col += j + 1 - i
            i = j + 1
            continue
        if ch.isalpha() or ch == "_":
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            word = text[i:j]
            if word in _OPENERS and (stmt_word is None or word != "if" or stmt_word[0] != "else"):
                stmt_word = (word, line, col) if stmt_word is None or word != "if" else stmt_word
            last_word = (word, line, col)
            col += j - i
            i = j
            continue
        if ch == "{":
            opener = stmt_word or last_word or ("{", line, col)
            stack.append((opener[0], opener[1], opener[2]))
            stmt_word = None
        elif ch == "}":
            if stack:
                stack.pop()
            stmt_word = None
        if ch == "\n":
            line, col = line + 1, 1
        else:
            col += 1
        i += 1
    return stack[-1] if stack else None


def syntax_error(exc, text: str, file: str, lark) -> HilaSyntaxError:
    """lark's ``UnexpectedInput`` for ``text`` as a :class:`HilaSyntaxError`: what was found,
    what was expected, the innermost block left open, a common slip named when recognised.
    ``lark`` is the parser that raised it (its terminals name what was expected, and the slips
    are matched against its states)."""
    # lazy: loads lark, which importing this module does not
    from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedToken

    line = getattr(exc, "line", None)
    column = getattr(exc, "column", None)
    hint = None
    at_end = isinstance(exc, UnexpectedEOF) or (
        isinstance(exc, UnexpectedToken) and exc.token.type == "$END"
    )
    if at_end:
        block = _unclosed_block(text)
        if block is not None:
            word, bline, bcol = block
            what = "main" if word == "main" else word
            return HilaSyntaxError(
                f"unexpected end of file: the '{what}' block opened here is never closed",
                file=file, line=bline, column=bcol, source_line=source_line(text, bline),
                hint="add '}' to close it",
            )
        lines = text.splitlines() or [""]
        line, column = len(lines), len(lines[-1]) + 1
        expected = getattr(exc, "expected", None) or []
        message = _with_expected("unexpected end of file", expected, lark)
    elif isinstance(exc, UnexpectedCharacters):
        ch = exc.char
        shown = repr(ch) if not ch.isprintable() or ch.isspace() else f"'{ch}'"
        message = f"unexpected character {shown}"
        if ch == '"':
            message = "unterminated string: a string ends with '\"' on the same line"
    elif isinstance(exc, UnexpectedToken):
        tok = exc.token
        kinds = {"NAME": "name", "NUMBER": "number", "STRING": "string"}
        shown = str(tok) if len(tok) <= 60 else f"{tok[:28]}...{tok[-28:]}"  # a giant string or name
        found = f"{kinds[tok.type]} '{shown}'" if tok.type in kinds else f"'{shown}'"
        if tok.type == "RBRACE" and _unclosed_block(text[: tok.start_pos]) is None:
            message = "unmatched '}': no block is open here"
        else:
            message = _with_expected(f"unexpected {found}", exc.expected, lark)
    else:  # pragma: no cover - lark's other errors are not raised by an LALR parse
        message = str(exc).splitlines()[0]
    if not at_end:
        try:
            label = exc.match_examples(functools.partial(lark.parse, start="start"), COMMON_SLIPS,
                                       use_accepts=True)
        except Exception:  # noqa: BLE001 - a failed guess must never hide the real error
            label = None
        if label:
            hint = label
    return HilaSyntaxError(
        message, file=file, line=line, column=column,
        source_line=source_line(text, line) if line else None, hint=hint,
    )
