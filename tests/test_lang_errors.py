"""User-facing error texts are an interface: message, line, column, source line and caret pinned."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest

from hila_lang import cli
from hila_lang.core.errors import CheckError, HilaRuntimeError, HilaSyntaxError
from hila_lang.language.checker import check
from hila_lang.language.compiler import compile_program
from hila_lang.language.transformer import parse_program

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)  # `import reach` finds primitives/reach.yaml


def front_end(src: str):
    return compile_program(check(parse_program(textwrap.dedent(src).lstrip("\n"), "t.hila")))


def err(kind, src: str) -> str:
    with pytest.raises(kind) as info:
        front_end(src)
    exc = info.value
    assert exc.line is not None and exc.column is not None
    return str(exc)


# (error class, program, the whole rendered error)
CASES = [
    (HilaSyntaxError, "main { run a.b }",
     "t.hila:1:16: error: unexpected '}'; expected '('\n    main { run a.b }\n                   ^\n"
     "hint: a run needs its ICP bindings in parentheses: run TEMPLATE.TAG(icp = point, ...)"),
    (HilaSyntaxError, "main { if x = 1 { } }",
     "t.hila:1:13: error: unexpected '='\n    main { if x = 1 { } }\n                ^\n"
     "hint: '=' binds a name; compare with '=='"),
    (HilaSyntaxError, "main {\n  while true {\n    wait bell\n",
     "t.hila:2:3: error: unexpected end of file: the 'while' block opened here is never closed\n"
     "      while true {\n      ^\nhint: add '}' to close it"),
    (HilaSyntaxError, "main { }\n}\n",
     "t.hila:2:1: error: unmatched '}': no block is open here\n    }\n    ^"),
    (HilaSyntaxError, 'main { let x = "abc\n}\n',
     "t.hila:1:16: error: unterminated string: a string ends with '\"' on the same line\n"
     '    main { let x = "abc\n                   ^'),
    (HilaSyntaxError, "main { @ }",
     "t.hila:1:8: error: unexpected character '@'\n    main { @ }\n           ^"),
    (HilaSyntaxError, "run a.b()",
     "t.hila:1:1: error: unexpected 'run'; expected ';', 'hand', 'import', 'main', 'point', 'task' or 'world'\n"
     "    run a.b()\n    ^\nhint: statements belong inside 'main { ... }' or a 'task NAME(params) { ... }'"),
    (HilaSyntaxError, "main { if true { } elif true { } }",
     "t.hila:1:25: error: unexpected 'true'; expected '('\n    main { if true { } elif true { } }\n"
     "                            ^\nhint: write 'else if', not 'elif'"),
    (HilaSyntaxError, "task t { }",
     "t.hila:1:8: error: unexpected '{'; expected '('\n    task t { }\n           ^\n"
     "hint: a task definition needs a parameter list: task NAME(params) { ... }"),
    (HilaSyntaxError, "main { f(1 2) }",
     "t.hila:1:12: error: unexpected number '2'\n    main { f(1 2) }\n               ^\n"
     "hint: separate arguments with ','"),
    (CheckError, """
        import reach
        main {
            run reach.bak(object = (0.3, 0, 0.6), home = hand)
        }""",
     "t.hila:3:15: error: template 'reach' has no sub-template 'bak'\n"
     "        run reach.bak(object = (0.3, 0, 0.6), home = hand)\n                  ^\nhint: did you mean 'back'?"),
    (CheckError, """
        import reach
        main {
            run reech.reach(object = (0.3, 0, 0.6), home = hand)
        }""",
     "t.hila:3:9: error: unknown template 'reech'\n"
     "        run reech.reach(object = (0.3, 0, 0.6), home = hand)\n            ^\nhint: did you mean 'reach'?"),
    (CheckError, """
        import reach
        main {
            run reach.reach(objet = (0.3, 0, 0.6), home = hand)
        }""",
     "t.hila:3:21: error: 'reach.reach' has no ICP 'objet'\n"
     "        run reach.reach(objet = (0.3, 0, 0.6), home = hand)\n                        ^\n"
     "hint: did you mean 'object'?"),
    (CheckError, """
        import reach
        main {
            run reach.reach(object = (0.3, 0, 0.6))
        }""",
     "t.hila:3:5: error: unbound ICP 'home' of 'reach.reach'\n"
     "        run reach.reach(object = (0.3, 0, 0.6))\n        ^\n"
     "hint: bind it, e.g. home = POINT, or leave it out on purpose with home = none"),
    (CheckError, """
        import reach
        task visit(x) { run reach.reach(object = x, home = hand) }
        main {
            vist((0.3, 0, 0.6))
        }""",
     "t.hila:4:5: error: unknown task 'vist'\n        vist((0.3, 0, 0.6))\n        ^\nhint: did you mean 'visit'?"),
    (CheckError, """
        import reach
        task visit(x) { run reach.reach(object = x, home = hand) }
        main {
            visit((0.3, 0, 0.6), 2)
        }""",
     "t.hila:4:5: error: task 'visit' takes 1 argument(s) (x), got 2\n"
     "        visit((0.3, 0, 0.6), 2)\n        ^\nhint: defined at line 2"),
    (CheckError, "task a() { b() }\ntask b() { a() }\nmain { a() }",
     "t.hila:2:12: error: task 'a' calls itself (a -> b -> a)\n    task b() { a() }\n               ^\n"
     "hint: tasks are compiled inline into the FSM, so recursion is not allowed; use a loop"),
    (CheckError, """
        import reach
        main {
            let target = (0.3, 0, 0.6)
            run reach.reach(object = targt, home = hand)
        }""",
     "t.hila:4:30: error: unknown name 'targt'\n"
     "        run reach.reach(object = targt, home = hand)\n                                 ^\n"
     "hint: did you mean 'target'?"),
    (CheckError, """
        import reach
        main {
            while true { wait bell }
            run reach.back(object = (0.3, 0, 0.6), home = hand)
        }""",
     "t.hila:4:5: error: unreachable statement: state 'main/back' can never run\n"
     "        run reach.back(object = (0.3, 0, 0.6), home = hand)\n        ^\n"
     "hint: a loop before it never ends, or a condition is always false"),
    (CheckError, "world tictactoo\nmain { }",
     "t.hila:1:1: error: unknown world 'tictactoo'\n    world tictactoo\n    ^\nhint: did you mean 'tictactoe'?"),
    (CheckError, "task t() { }\n",
     "t.hila:1:1: error: the program has no entry point\n    task t() { }\n    ^\n"
     "hint: add 'main { ... }' with the statements to run"),
    (CheckError, "main { repeat 0 { } }",
     "t.hila:1:8: error: 'repeat 0' never runs its block\n    main { repeat 0 { } }\n           ^\n"
     "hint: remove it, or repeat at least once"),
    (CheckError, "task t() { }\ntask t() { }\nmain { t() }",
     "t.hila:2:1: error: task 't' is defined twice (first at line 1)\n    task t() { }\n    ^"),
    (CheckError, "import reach\nmain { run reach.reach(object = (0.3, 0, 0.6), object = hand, home = hand) }",
     "t.hila:2:48: error: ICP 'object' is bound twice\n"
     "    main { run reach.reach(object = (0.3, 0, 0.6), object = hand, home = hand) }\n"
     "                                                   ^\nhint: first bound at column 24"),
    (CheckError, "task t(hand) { }\nmain { t(1) }",
     "t.hila:1:8: error: 'hand' is reserved and cannot be a parameter\n    task t(hand) { }\n           ^"),
]


@pytest.mark.parametrize("kind,src,expected", CASES, ids=[f"{i:02d}" for i in range(len(CASES))])
def test_error_text_is_pinned(kind, src, expected):
    assert err(kind, src) == expected


def test_at_least_a_dozen_distinct_messages():
    messages = {e.split("\n")[0].split("error: ")[1] for _, _, e in CASES}
    assert len(messages) >= 12


def test_missing_template_names_the_folders_and_suggests():
    with pytest.raises(CheckError, match=r"template 'reahc' not found \(looked in .*primitives") as info:
        front_end("import reahc\nmain { }")
    assert info.value.hint == "did you mean 'reach'?"
    assert (info.value.line, info.value.column) == (1, 1)


def test_non_utf8_program_is_a_syntax_error_with_position(tmp_path):
    bad = tmp_path / "bad.hila"
    bad.write_bytes(b"main {\n  wait b\xffell\n}\n")
    from hila_lang.language.source import read_source

    with pytest.raises(HilaSyntaxError, match=r"not UTF-8 text \(byte 0xff\)") as info:
        read_source(bad)
    assert (info.value.line, info.value.column) == (2, 9)


def test_cli_check_prints_error_and_exits_2(tmp_path, capsys):
    prog = tmp_path / "p.hila"
    prog.write_text("main { run a.b }\n")
    assert cli.main(["check", str(prog)]) == 2
    err_text = capsys.readouterr().err
    assert re.match(rf"{re.escape(str(prog))}:1:16: error: unexpected '}}'", err_text)
    assert "Traceback" not in err_text


def test_runtime_error_names_state_and_line(tmp_path, capsys):
    prog = tmp_path / "p.hila"
    prog.write_text("import reach\nmain {\n    run reach.reach(object = (0.3, -0.1, 0.6) / 0, home = hand)\n}\n")
    assert cli.main(["exec", str(prog), "--quiet"]) == 1
    err_text = capsys.readouterr().err
    assert err_text.startswith(f"{prog}:3:5: error: division by zero in '(0.3, -0.1, 0.6) / 0' (in state main/reach)\n")
    assert "    run reach.reach(object = (0.3, -0.1, 0.6) / 0, home = hand)\n" in err_text
    assert "Traceback" not in err_text


def test_an_unknown_world_point_is_found_by_check(tmp_path, capsys):
    prog = tmp_path / "p.hila"
    prog.write_text("import reach\nmain {\n    run reach.reach(object = shelf.top, home = hand)\n}\n")
    for command in ("check", "exec"):
        assert cli.main([command, str(prog)]) == 2
        err_text = capsys.readouterr().err
        assert err_text.startswith(f"{prog}:3:30: error: unknown scene point 'shelf.top' (the scripted world "
                                   "(no --set script=FILE.yaml) does not name it)\n")


def test_runtime_error_from_world_question(tmp_path):
    from hila_lang.language import load_program
    from hila_lang.robot.dry import DryBackend
    from hila_lang.engine.interpreter import Interpreter
    from hila_lang.worlds.scripted.world import ScriptedWorld

    prog = tmp_path / "p.hila"
    prog.write_text("main {\n  if ask raining { wait sun }\n}\n")
    checked, fsm = load_program(prog)
    interp = Interpreter(checked, fsm, ScriptedWorld(), DryBackend())
    with pytest.raises(HilaRuntimeError) as info:
        interp.step()
    assert info.value.state == "main/if#1"
    assert (info.value.line, info.value.column) == (2, 3)
    assert "the scripted world has no question 'raining'" in str(info.value)
    assert interp.current == "main/if#1"  # a failed step does not advance
