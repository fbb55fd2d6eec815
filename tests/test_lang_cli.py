"""``hila check``, ``hila compile``, ``hila exec`` through the real command line (cli.main)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hila_lang import cli

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def test_language_commands_are_registered():
    for name in ("check", "compile", "exec", "repl"):
        assert name in cli.COMMANDS, f"hila {name} is not in hila_lang.cli.COMMANDS"


def test_check_ok_and_warning(tmp_path, capsys):
    prog = tmp_path / "p.hila"
    prog.write_text("task unused() { wait e }\nmain { wait e }\n")
    script = tmp_path / "s.yaml"
    script.write_text("events: {e: [1]}\n")  # the scripted world's events come from its script
    assert cli.main(["check", "programs/abc.hila", str(prog), "--set", f"script={script}"]) == 0
    out, err = capsys.readouterr()
    assert "programs/abc.hila: ok (6 states, 5 run states, world scripted)" in out
    assert f"{prog}:1:1: warning: task 'unused' is never called" in err


def test_check_reports_every_file_and_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.hila"
    bad.write_text("main { run abc.a( }\n")
    assert cli.main(["check", str(bad), "programs/reach_return.hila"]) == 2
    out, err = capsys.readouterr()
    assert "reach_return.hila: ok" in out
    assert f"{bad}:1:" in err and "^" in err


def test_compile_formats(capsys):
    assert cli.main(["compile", "programs/abc.hila", "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["start"] == "main/c#1"
    assert [s["name"] for s in doc["states"]] == ["main/c#1", "main/b", "main/a#1", "main/a#2", "main/c#2", "end"]
    assert doc["states"][0]["bindings"] == {"r": "table.r", "p": "none", "q": "none", "hand": "none"}
    assert cli.main(["compile", "programs/abc.hila", "--format", "dot"]) == 0
    dot = capsys.readouterr().out
    assert dot.startswith("digraph hila {") and '"main/c#1" -> "main/b";' in dot
    assert cli.main(["compile", "programs/abc.hila", "--format", "text"]) == 0
    assert "main/a#2  line  21  run abc.a" in capsys.readouterr().out
    assert cli.main(["compile", "programs/abc.hila", "--format", "ast"]) == 0
    assert capsys.readouterr().out.startswith("ImportDecl @7:1  source='abc' alias='abc' is_path=False")


def test_exec_dry_with_trace_file(tmp_path, capsys):
    trace = tmp_path / "trace.txt"
    assert cli.main(["exec", "programs/reach_return.hila", "--backend", "dry", "--trace", str(trace), "--quiet"]) == 0
    assert capsys.readouterr().out == "result: finished: 22 steps, 10 run states\n"  # --quiet: the result only
    lines = trace.read_text().splitlines()
    assert len(lines) == 22 and lines[-1].endswith("end")
    assert lines[1].startswith("  2  main/visit#1/reach  [line 12]  run reach.reach pen up: 36 points")


def test_exec_with_world_script_and_osila_setting(capsys):
    args = ["exec", "tests/programs/game_sample.hila", "--set", "script=tests/programs/game_sample.world.yaml",
            "--set", "osila.threshold=0.001"]
    assert cli.main(args) == 0
    out = capsys.readouterr().out
    assert out.count("run circle.draw pen down") == 3


def test_exec_bad_setting_is_bad_input(capsys):
    assert cli.main(["exec", "programs/abc.hila", "--set", "osila.treshold=1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "unknown OSILA option 'treshold'" in err and "did you mean 'osila.threshold'?" in err


def test_missing_program_is_exit_2(capsys):
    assert cli.main(["check", "programs/nope.hila"]) == 2
    assert "programs/nope.hila: error: program not found" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["exec", "repl"])
@pytest.mark.parametrize("seed", ["-3", "x"])
def test_bad_seed_is_refused_before_the_run(command, seed, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main([command, "programs/abc.hila", "--seed", seed])
    assert exc.value.code == 2
    assert "argument --seed: expected a whole number >= 0" in capsys.readouterr().err


@pytest.mark.parametrize("program, key, hint", [
    ("programs/game.hila", "frist", "did you mean 'first'?"),
    ("programs/abc.hila", "scirpt", "did you mean 'script'?"),
])
def test_an_unknown_setting_is_refused_not_ignored(program, key, hint, capsys):
    assert cli.main(["exec", program, "--backend", "dry", "--quiet", "--set", f"{key}=x"]) == 2
    err = capsys.readouterr().err
    assert f"unknown setting {key!r}" in err and hint in err
