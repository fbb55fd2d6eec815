"""Fuzzing the front end: whatever the bytes, only hila's own errors, each with line and column.

Seeded mutations of every example program (deleted, duplicated and swapped tokens, random
bytes spliced in), hypothesis-generated text, non-UTF-8 input and a 1 MB program.
"""

from __future__ import annotations

import random
import re
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hila_lang.core.errors import HilaError
from hila_lang.language.checker import check
from hila_lang.language.compiler import compile_program
from hila_lang.language.source import decode_source
from hila_lang.language.transformer import parse_program

ROOT = Path(__file__).resolve().parent.parent
SOURCES = [p.read_text() for p in sorted((ROOT / "programs").glob("*.hila"))
           + sorted((ROOT / "tests" / "programs").glob("*.hila"))]
TOKEN = re.compile(r'"[^"\n]*"|#[^\n]*|[A-Za-z_][A-Za-z_0-9]*|\d+(?:\.\d*)?|==|!=|<=|>=|\.\*|\S')


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def front_end(data: bytes) -> None:
    """Decode, parse, check, compile; only HilaError may escape, and it must carry a position."""
    try:
        text = decode_source(data, "fuzz.hila")
        compile_program(check(parse_program(text, "fuzz.hila")))
    except HilaError as exc:
        assert exc.line is not None and exc.line >= 1, f"no line in: {exc}"
        assert exc.column is not None and exc.column >= 1, f"no column in: {exc}"
        str(exc)  # renders
        raise


def mutate(text: str, rng: random.Random) -> str:
    tokens = [(m.start(), m.end()) for m in TOKEN.finditer(text)]
    i = rng.randrange(len(tokens))
    a, b = tokens[i]
    kind = rng.choice(["delete", "duplicate", "swap", "bytes"])
    if kind == "delete":
        return text[:a] + text[b:]
    if kind == "duplicate":
        return text[:b] + " " + text[a:b] + text[b:]
    if kind == "swap":
        c, d = tokens[rng.randrange(len(tokens))]
        if c < a:
            (a, b), (c, d) = (c, d), (a, b)
        if c < b:
            return text
        return text[:a] + text[c:d] + text[b:c] + text[a:b] + text[d:]
    junk = "".join(chr(rng.randrange(0, 0x250)) for _ in range(rng.randrange(1, 4)))
    return text[:a] + junk + text[a:]


def survive(data: bytes) -> None:
    """:func:`front_end`, where a positioned HilaError is a fine outcome."""
    try:
        front_end(data)
    except HilaError:
        pass


@pytest.mark.parametrize("seed", range(6))
def test_seeded_token_mutations(seed):
    rng = random.Random(seed)
    failures = 0
    for _ in range(60):
        text = rng.choice(SOURCES)
        for _ in range(rng.randrange(1, 4)):
            text = mutate(text, rng)
        try:
            front_end(text.encode("utf-8", "surrogatepass"))
        except HilaError:
            failures += 1
    assert failures > 0  # the mutations do break programs, so the error paths were exercised


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=300))
def test_random_bytes(data):
    survive(data)


ALPHABET = st.sampled_from(
    ["main", "task", "run", "let", "wait", "if", "else", "while", "until", "repeat", "ask", "import",
     "world", "point", "hand", "at", "pen", "down", "reach", "reach.reach", "x", "(", ")", "{", "}",
     ",", "=", "==", ".*", "1", "0.5", '"s"', "none", "true", "not", "and", "+", "-", "\n", " ", "#c\n"])


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(ALPHABET, max_size=40))
def test_token_soup(tokens):
    survive(" ".join(tokens).encode())


def test_non_utf8_bytes_inside_a_program():
    data = SOURCES[0].encode()
    for cut in (0, len(data) // 2, len(data) - 1):
        with pytest.raises(HilaError, match="not UTF-8"):
            front_end(data[:cut] + b"\xc3\x28\xff" + data[cut:])


@pytest.mark.slow
def test_one_megabyte_program():
    body = "    wait tick\n" * (1_000_000 // 14)
    text = "main {\n" + body + "\n  wait tock\n  }\n}\n"  # one '}' too many at the very end
    assert len(text) >= 1_000_000
    with pytest.raises(HilaError) as info:
        front_end(text.encode())
        raise AssertionError("the stray '}' was not reported")
    assert (info.value.line, info.value.column) == (text.count("\n"), 1)
    assert "unmatched '}'" in info.value.message


def test_deep_nesting_is_reported_not_crashed():
    front_end(("main { let x = " + "(" * 5000 + "1" + ")" * 5000 + " }").encode())  # parentheses fold away
    front_end(("main { let x = " + "-(" * 3000 + "1" + ")" * 3000 + " }").encode())  # so does -(-(1))
    for text in ("main { let x = " + "not " * 5000 + "true }",
                 "main { let x = " + "-(" * 3000 + "x" + ")" * 3000 + " }",
                 "main { " + "if true { " * 3000 + "} " * 3000 + "}"):
        with pytest.raises(HilaError, match="nests too deeply"):
            front_end(text.encode())


def test_moderate_nesting_still_compiles():
    front_end(("main { " + "if true { " * 60 + "wait e " + "} " * 60 + "}").encode())
