"""Expressions are read flat and built by precedence (transformer._precedence): the same trees a
grammar level per operator would give, the same refusals, and spans as written."""

import re

import pytest

from hila_lang.core.errors import HilaSyntaxError
from hila_lang.language import ast as A
from hila_lang.language.transformer import parse_expr


def shape(e):
    """An expression as nested tuples, positions left out."""
    if isinstance(e, A.Binary):
        return (e.op, shape(e.left), shape(e.right))
    if isinstance(e, A.Unary):
        return (e.op, shape(e.operand))
    if isinstance(e, A.Name):
        return e.text
    if isinstance(e, A.Number):
        return e.value
    return type(e).__name__


@pytest.mark.parametrize("text, tree", [
    ("a + b * c", ("+", "a", ("*", "b", "c"))),
    ("a * b + c", ("+", ("*", "a", "b"), "c")),
    ("a - b - c", ("-", ("-", "a", "b"), "c")),  # left to right within a level
    ("a / b * c", ("*", ("/", "a", "b"), "c")),
    ("a or b and c", ("or", "a", ("and", "b", "c"))),
    ("a and b or c and d", ("or", ("and", "a", "b"), ("and", "c", "d"))),
    ("not a and b", ("and", ("not", "a"), "b")),
    ("not a == b", ("not", ("==", "a", "b"))),  # 'not' takes the whole comparison
    ("not a + 1 < b", ("not", ("<", ("+", "a", 1.0), "b"))),
    ("not not a", ("not", ("not", "a"))),
    ("-a * b", ("*", ("-", "a"), "b")),  # unary minus binds tightest
    ("- -a", ("-", ("-", "a"))),
    ("-2.5 + a", ("+", -2.5, "a")),  # folded into the literal
    ("a == b or c != d", ("or", ("==", "a", "b"), ("!=", "c", "d"))),
    ("(a + b) * c", ("*", ("+", "a", "b"), "c")),
    ("a < b + c * -d", ("<", "a", ("+", "b", ("*", "c", ("-", "d"))))),
])
def test_precedence_and_grouping(text, tree):
    assert shape(parse_expr(text)) == tree


@pytest.mark.parametrize("text, message, column", [
    ("a < b < c", "comparisons do not chain", 7),
    ("a == b != c", "comparisons do not chain", 8),
    ("a + not b", "'not' cannot follow '+'", 5),
    ("a == not b", "'not' cannot follow '=='", 6),
])
def test_what_a_grammar_level_per_operator_refused_is_still_refused(text, message, column):
    with pytest.raises(HilaSyntaxError, match=re.escape(message)) as info:
        parse_expr(text)
    assert info.value.column == column


def test_spans_as_written():
    e = parse_expr("a + b + c")
    assert (e.pos.column, e.pos.end_column) == (1, 10) and (e.left.pos.column, e.left.pos.end_column) == (1, 10)
    e = parse_expr("x * (a + b)")
    assert (e.right.pos.column, e.right.pos.end_column) == (5, 12)  # the brackets included
    e = parse_expr("not a and b")
    assert (e.pos.column, e.left.pos.column, e.left.operand.pos.column) == (1, 1, 5)
    e = parse_expr("-x * 2")
    assert (e.left.pos.column, e.left.pos.end_column) == (1, 3)


def test_a_long_chain_builds_without_recursion():
    from hila_lang.language.transformer import parse_items

    e = parse_items(" + ".join(["a"] * 5000), "expr")
    depth = 0
    while isinstance(e, A.Binary):
        e, depth = e.left, depth + 1
    assert depth == 4999


def test_hila_check_locates_them_in_the_file(tmp_path, capsys):
    from hila_lang.cli import main

    p = tmp_path / "p.hila"
    p.write_text("main {\n  let a = 1\n  if a + not a { let b = 2 }\n}\n")
    assert main(["check", str(p)]) == 2
    err = capsys.readouterr().err
    assert f"{p}:3:10: error: 'not' cannot follow '+'" in err and "Traceback" not in err
