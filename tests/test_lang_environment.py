"""The front end is one object: :class:`hila_lang.language.environment.Environment`.

- one grammar load in the whole package, no private lark API, no module-level mutable span;
- the stages stop where asked and the text is parsed once;
- templates are found and read through the environment's loader (cached while unchanged);
- no module below ``commands/`` imports ``cli``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hila_lang.core.errors import CheckError
from hila_lang.language import ast as A
from hila_lang.language.checker import CheckedProgram
from hila_lang.language.environment import Environment
from hila_lang.language.fsm import FSM
from hila_lang.language.loader import TemplateLoader

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "hila_lang"
SOURCES = {p: p.read_text() for p in PACKAGE.rglob("*.py")}

PROGRAM = """\
import reach
point home = (0.18, -0.25, 0.75)
task unused() { run reach.reach(object = home, home = home) }
main { run reach.reach(object = home, home = home) }
"""


def test_one_grammar_load_and_no_private_lark_api():
    constructions = [(p, m.group(0)) for p, s in SOURCES.items() for m in re.finditer(r"\bLark(\.open)?\(", s)]
    assert len(constructions) == 1, constructions
    assert not [p for p, s in SOURCES.items() if "_callbacks" in s]
    assert "_span" not in SOURCES[PACKAGE / "language" / "transformer.py"]


def test_no_module_below_commands_imports_cli():
    below = [p for p in SOURCES if p.parent.name != "commands" and p.name not in ("cli.py", "__main__.py")]
    offenders = [p for p in below if re.search(r"from \.+cli import|import hila_lang\.cli|from hila_lang\.cli|"
                                                 r"from \.+ import cli\b|from hila_lang import cli\b", SOURCES[p])]
    assert offenders == []


def test_the_stages_stop_where_asked_and_parse_once(monkeypatch, tmp_path):
    monkeypatch.chdir(ROOT)
    env = Environment()
    ast = env.compile(PROGRAM, "p.hila", stop="ast")
    assert isinstance(ast, A.Program) and ast.file == "p.hila"
    checked = env.compile(PROGRAM, "p.hila", stop="check")
    assert isinstance(checked, CheckedProgram) and "reach" in checked.templates
    parses = []
    real = env.parse
    monkeypatch.setattr(env, "parse", lambda *a: parses.append(a) or real(*a))
    checked, fsm = env.compile(PROGRAM, "p.hila")
    assert isinstance(fsm, FSM) and len(parses) == 1
    with pytest.raises(ValueError, match="stop must be one of ast, check, fsm"):
        env.compile(PROGRAM, stop="tree")


def test_warnings_are_structured_and_print_as_before(monkeypatch):
    monkeypatch.chdir(ROOT)
    checked, _ = Environment().compile(PROGRAM, "p.hila")
    (w,) = checked.warnings
    assert w == "p.hila:3:1: warning: task 'unused' is never called"
    assert (w.code, w.message, w.severity) == ("unused-task", "task 'unused' is never called", "warning")
    assert (w.pos.line, w.pos.column, w.pos.end_line, w.pos.end_column) == (3, 1, 3, 5)


def test_templates_come_through_the_loader_once_while_unchanged(tmp_path):
    source = (ROOT / "primitives" / "reach.yaml").read_text()
    (tmp_path / "mine.yaml").write_text(source)
    env = Environment(search_path=[tmp_path])
    text = PROGRAM.replace("reach", "mine").replace("mine.mine", "mine.reach")
    first = env.compile(text, str(tmp_path / "p.hila"), stop="check").templates["mine"]
    again = env.compile(text, str(tmp_path / "p.hila"), stop="check").templates["mine"]
    assert again is first  # cached
    (tmp_path / "mine.yaml").write_text(source + "\n# edited\n")
    assert env.compile(text, str(tmp_path / "p.hila"), stop="check").templates["mine"] is not first
    with pytest.raises(CheckError, match=r"template 'reach' not found \(looked in " + re.escape(str(tmp_path))):
        env.compile(PROGRAM, str(tmp_path / "p.hila"), stop="check")  # only the folders given


def test_the_default_environment_is_shared_and_keywords_come_from_the_grammar():
    env = Environment.default()
    assert Environment.default() is env and isinstance(env.templates, TemplateLoader)
    words = env.keywords
    grammar = (ROOT / "grammar" / "hila.lark").read_text()
    assert {"run", "ask", "wait", "via", "avoid", "radius", "up", "down", "true", "none"} <= set(words)
    assert all(f'"{w}"' in grammar for w in words)
    assert "NAME" not in words and "." not in words


def test_the_call_checks_state_count_is_the_compilers(monkeypatch):
    """calls.py counts the states each statement compiles to (to refuse a program that inlines
    too big before compiling it); one statement of every kind: its count is the FSM's."""
    from hila_lang.language.calls import _body

    monkeypatch.chdir(ROOT)
    src = """import reach
point home = (0.18, -0.25, 0.75)
task t(p) { run reach.reach(object = p, home = home) }
main {
  run reach.reach(object = home, home = home)
  let a = 1
  let b = wait e
  wait e
  t(home)
  if a > 1 { let c = 2 } else if a > 2 { let d = 1 } else { let e = 3 }
  while a < 1 { let a = a + 1 }
  until a > 3 { let a = a + 1 }
  repeat 3 { let f = 1 }
}
"""
    checked, fsm = Environment().compile(src, "x.hila")
    own = _body(checked.main).states + _body(checked.tasks["t"]).states
    assert own + 1 == len(fsm.states)  # and the end state
