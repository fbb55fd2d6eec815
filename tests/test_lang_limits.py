"""Hostile programs end in a located error or a success, never a traceback (issue 13).

Long flat expressions and call chains, deep nesting at and past the limit, a byte-order mark,
control characters and giant lines in messages; and the AST built while parsing is the AST the
tree walk builds, positions included.
"""

from __future__ import annotations

import functools

import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hila_lang import cli
from hila_lang.core.errors import CheckError, HilaSyntaxError, printable, show_source
from hila_lang.language import ast as A
from hila_lang.language.calls import MAX_STATES
from hila_lang.language.checker import check
from hila_lang.language.compiler import compile_program
from hila_lang.language.limits import MAX_NESTING
from hila_lang.language.source import decode_source, syntax_error
from hila_lang.language.transformer import parse_program, to_ast

ROOT = Path(__file__).resolve().parent.parent
PROGRAMS = sorted((ROOT / "programs").glob("*.hila")) + sorted((ROOT / "tests" / "programs").glob("*.hila"))


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def front_end(text: str, file: str = "t.hila"):
    return compile_program(check(parse_program(text, file)))


def cli_run(tmp_path, capsys, text: str, *command: str) -> tuple[int, str]:
    prog = tmp_path / "p.hila"
    prog.write_text(text, encoding="utf-8")
    code = cli.main([*command, str(prog)])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err.replace(str(prog), "p.hila")


# --------------------------------------------------------------------------- long and deep


@pytest.mark.parametrize("operator, n", [("+", 1000), (" and ", 2000), ("*", 2000)])
def test_long_flat_expressions_are_located_errors_in_check_and_exec(tmp_path, capsys, operator, n):
    term = "true" if operator == " and " else "1"
    text = "main { let x = " + operator.join([term] * n) + " }\n"
    for command in ("check", "exec"):
        code, err = cli_run(tmp_path, capsys, text, command)
        assert code == 2
        first, shown, caret, hint = err.splitlines()
        assert first == (f"p.hila:1:16: error: the program nests too deeply here: 1 block and {n} expression "
                         f"levels, {n + 1} levels (at most {MAX_NESTING})")
        assert len(shown) <= 110 and shown.endswith("...") and caret == " " * 19 + "^"
        assert hint == ("hint: compute part of the expression first with 'let': each operator of a chain "
                        "like a + b + c nests one level")


def test_nesting_message_counts_what_the_user_wrote(tmp_path, capsys):
    text = "main {\n" + "if true {\n" * 148 + "let x = 1\n" + "}\n" * 148 + "}\n"
    code, err = cli_run(tmp_path, capsys, text, "check")
    assert code == 2
    assert err.splitlines()[0] == ("p.hila:150:9: error: the program nests too deeply here: 149 blocks one "
                                   "inside another and 1 expression level, 150 levels (at most 100)")
    assert err.splitlines()[-1] == "hint: move inner blocks into tasks"


def test_a_chain_of_800_tasks_is_a_located_error(tmp_path, capsys):
    text = "\n".join(f"task t{i}() {{ t{i + 1}() }}" for i in range(800)) + "\ntask t800() { let y = 1 }\nmain { t0() }\n"
    code, err = cli_run(tmp_path, capsys, text, "check")
    assert code == 2
    assert err.splitlines()[0] == ("p.hila:802:8: error: task calls nest too deeply: main -> t0 -> t1 -> t2 -> "
                                   "... -> t798 -> t799 -> t800 inlines to 803 levels of blocks and expressions "
                                   "(at most 100)")


def test_calls_that_double_at_every_level_are_refused_not_compiled():
    text = "\n".join(f"task t{i}() {{ t{i + 1}()\n t{i + 1}() }}" for i in range(40)) + "\ntask t40() { let y = 1 }\nmain { t0() }\n"
    with pytest.raises(CheckError) as info:
        front_end(text)
    assert info.value.message == (f"the program would compile to about 10^12 states (at most {MAX_STATES:,}): "
                                  "every call copies its task's states, and this call alone copies about 10^12")
    assert (info.value.line, info.value.column) == (82, 8)


def test_a_long_chain_of_points_is_a_located_error():
    text = "point p0 = (0, 0, 0)\n" + "".join(f"point p{i + 1} = p{i} + (0.001, 0, 0)\n" for i in range(300)) + "main { }\n"
    with pytest.raises(CheckError, match=r"point 'p50' is defined through points defined through points \.\.\. "
                                         r"102 levels deep \(at most 100\)") as info:
        front_end(text)
    assert (info.value.line, info.value.column) == (51, 1)


def test_every_stage_at_the_limit_fits_well_inside_the_stack():
    """Programs exactly at MAX_NESTING go through every stage (parse, check, compile, FSM JSON and
    back, text, DOT, AST dump, a dry run) with Python's recursion limit lowered to 4.5 frames per
    level: the limit keeps the deepest walk (measured 4.05 frames per level) well inside the
    default 1000."""
    import json

    from hila_lang.language.fsm import FSM
    from hila_lang.engine.interpreter import Interpreter
    from hila_lang.robot.dry import DryBackend
    from hila_lang.worlds.scripted.world import ScriptedWorld

    n = MAX_NESTING
    programs = {
        "blocks": "main {\n" + "if true {\n" * (n - 2) + "let x = 1\n" + "}\n" * (n - 2) + "}\n",
        "sum": "main { let x = " + "+".join(["1"] * (n - 1)) + " }\n",
        "not": "main { let x = " + "not " * (n - 2) + "true }\n",
        "mixed": "main {\n" + "while true {\n" * (n // 2 - 1) + "let x = " + "+".join(["1"] * (n // 2)) + "\n"
                 + "}\n" * (n // 2 - 1) + "}\n",
        "calls": "\n".join(f"task t{i}() {{ t{i + 1}() }}" for i in range(n - 3)) + f"\ntask t{n - 3}() {{ let y = 1 }}\nmain {{ t0() }}\n",
    }
    for name, text in programs.items():
        program = parse_program(text, "p.hila")  # outside the lowered limit: pytest's own frames
        depth = len(_frames())
        old = sys.getrecursionlimit()
        sys.setrecursionlimit(depth + int(4.5 * n))
        try:
            fsm = compile_program(check(parse_program(text, "p.hila")))
            assert FSM.from_dict(json.loads(fsm.to_json())) == fsm
            fsm.to_text(), fsm.to_dot(), A.dump(program.items)
            interp = Interpreter(check(program), fsm, ScriptedWorld(), DryBackend())
            interp.run(max_steps=500)
        finally:
            sys.setrecursionlimit(old)
    too_deep = "main { let x = " + "+".join(["1"] * n) + " }\n"  # one level more
    with pytest.raises(HilaSyntaxError, match="nests too deeply"):
        parse_program(too_deep, "p.hila")


def _frames():
    f, out = sys._getframe(), []
    while f is not None:
        out.append(f)
        f = f.f_back
    return out


# --------------------------------------------------------------------------- what messages show


def test_a_byte_order_mark_is_accepted(tmp_path, capsys):
    code, err = cli_run(tmp_path, capsys, "\ufeffmain { let x = 1 }\n", "check")
    assert code == 0 and err == ""
    code, err = cli_run(tmp_path, capsys, "\ufeffmain { let x = y }\n", "check")
    assert code == 2 and err.startswith("p.hila:1:16: error: unknown name 'y'")  # columns as the editor shows them
    assert decode_source(b"\xef\xbb\xbfmain { }") == "main { }"


def test_2000_open_braces_echo_a_clipped_line(tmp_path, capsys):
    code, err = cli_run(tmp_path, capsys, "main " + "{" * 2000 + "\n", "check")
    lines = err.splitlines()
    assert code == 2 and lines[0] == "p.hila:1:7: error: unexpected '{'; expected ';', '}' or a name"
    assert lines[1] == "    main " + "{" * 95 + "..." and lines[2] == "    " + " " * 6 + "^"
    assert max(map(len, lines)) <= 110


def test_control_characters_are_escaped_never_sent_raw(tmp_path, capsys):
    code, err = cli_run(tmp_path, capsys, "main { let x = \x1b[31m 1 }\n", "check")
    assert code == 2 and "\x1b" not in err
    assert err.splitlines() == ["p.hila:1:16: error: unexpected character '\\x1b'",
                                "    main { let x = \\x1b[31m 1 }", "    " + " " * 15 + "^"]
    code, err = cli_run(tmp_path, capsys, "main { let x = y\u202e }\n", "check")  # a right-to-left override
    assert code == 2 and "\u202e" not in err and "\\u202e" in err


def test_show_source_keeps_the_caret_under_the_column():
    line = "a\tb\x1bc" + "x" * 300 + "END"
    shown, caret = show_source(line, 4)  # the ESC
    assert shown.startswith("a b\\x1bc") and shown[caret:].startswith("\\x1b")
    shown, caret = show_source(line, len(line) - 2)  # the E of END
    assert shown.startswith("...") and shown[caret:] == "END" and len(shown) <= 106
    assert printable("ok\x07\n" + "y" * 1000).splitlines()[0] == "ok\\x07"
    assert len(printable("y" * 10_000)) <= 2000


# --------------------------------------------------------------------------- the AST parser


def _spans(node) -> list:
    """Every node of the tree with its full position, in a fixed order."""
    out, stack = [], [node]
    while stack:
        n = stack.pop()
        out.append((type(n).__name__, getattr(n, "pos", None)))
        stack.extend(reversed(A.children(n)))
    return out


@functools.lru_cache(maxsize=1)
def _tree_parser():
    """lark's plain tree parser of the same grammar (tests may build their own: the package
    builds exactly one, the in-parse AST builder)."""
    from lark import Lark

    from hila_lang.core.resources import grammar_path

    return Lark.open(str(grammar_path()), parser="lalr", propagate_positions=True, maybe_placeholders=True)


def _reference(text: str):
    from lark.exceptions import UnexpectedInput

    try:
        tree = _tree_parser().parse(text)
    except UnexpectedInput as exc:
        raise syntax_error(exc, text, "r.hila", _tree_parser()) from None
    return to_ast(tree, text, "r.hila")


@pytest.mark.parametrize("program", PROGRAMS, ids=lambda p: p.stem)
def test_the_ast_built_while_parsing_is_the_tree_walks_positions_included(program):
    text = program.read_text()
    fast, slow = parse_program(text, "r.hila"), _reference(text)
    assert fast == slow
    assert [_spans(i) for i in fast.items] == [_spans(i) for i in slow.items]


ATOM = st.sampled_from(["1", "0.5", "x", "a.b", '"s"', "true", "none", "(1, 2, 3)", "hand", "ask q"])
EXPR = st.recursive(
    st.one_of(ATOM, st.lists(ATOM, min_size=2, max_size=6).map(" + ".join)),
    lambda inner: st.one_of(
        st.tuples(inner, st.sampled_from([" + ", "-", " * ", " / ", " == ", " < ", " and ", " or "]), inner).map(
            lambda t: f"({''.join(t)})"),
        inner.map(lambda e: f"({e})"), inner.map(lambda e: f"-({e})"), inner.map(lambda e: f"(not {e})"),
        st.tuples(inner, inner).map(lambda t: f"({t[0]}, {t[1]})"),
        inner.map(lambda e: f"ask f({e})")),
    max_leaves=12)
STMT = st.recursive(
    st.one_of(EXPR.map(lambda e: f"let x = {e}"), EXPR.map(lambda e: f"run t.s(a = {e}, b.* )"),
              st.just("wait e"), EXPR.map(lambda e: f"g({e})")),
    lambda inner: st.one_of(
        st.tuples(EXPR, st.lists(inner, max_size=3)).map(lambda t: f"if {t[0]} {{ {' '.join(t[1])} }}"),
        st.tuples(EXPR, st.lists(inner, max_size=3), st.lists(inner, max_size=2)).map(
            lambda t: f"if {t[0]} {{ {' '.join(t[1])} }} else {{ {' '.join(t[2])} }}"),
        st.tuples(st.sampled_from(["while", "until", "repeat"]), EXPR, st.lists(inner, max_size=3)).map(
            lambda t: f"{t[0]} {t[1]} {{\n{chr(10).join(t[2])}\n}}")),
    max_leaves=8)


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(STMT, max_size=5), st.sampled_from(["", "\n", "  ", " # c\n"]))
def test_generated_programs_parse_to_the_same_ast_both_ways(stmts, gap):
    text = f"import t\npoint a.b = (1, 2, 3)\ntask g(v) {{ wait e }}\nmain {{{gap}" + gap.join(stmts) + "\n}\n"

    def outcome(parse):
        try:
            return [_spans(i) for i in parse(text).items]
        except HilaSyntaxError as exc:  # not every generated text is a program: the same error then
            return (exc.line, exc.column, exc.message)

    assert outcome(lambda t: parse_program(t, "r.hila")) == outcome(_reference)


def test_a_statement_whose_fields_are_its_rules_children_has_no_code_in_the_transformer():
    """``let``, ``wait``, ``while``, ``until`` and ``repeat`` are built by the transformer's one
    generic builder (their fields in the rule's order, a token as its text, then the position)."""
    from hila_lang.language import transformer

    text = "main {\n  let x = 1\n  wait e\n  while x { }\n  until x { }\n  repeat 2 { }\n}\n"
    body = parse_program(text, "g.hila").items[0].body
    assert body == (A.LetStmt("x", A.Number(1.0)), A.WaitStmt(A.Wait("e", ())), A.WhileStmt(A.Name(("x",)), ()),
                    A.UntilStmt(A.Name(("x",)), ()), A.RepeatStmt(A.Number(2.0), ()))
    assert [s.pos.line for s in body] == [2, 3, 4, 5, 6] and body[0].pos.column == 3
    generic = {rule for rule, cls in A.RULES.items()
               if transformer.ToAst.__dict__[rule].base_func.__qualname__.startswith("_generic")}
    assert generic == {"let_stmt", "wait_stmt", "while_stmt", "until_stmt", "repeat_stmt"}
