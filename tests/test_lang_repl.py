"""REPL transcripts driven through stdin, asserting the state after each step."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import pytest

from hila_lang.language import load_program
from hila_lang.robot.dry import DryBackend
from hila_lang.engine.interpreter import Interpreter
from hila_lang.session.repl import Repl
from hila_lang.worlds.scripted.world import load_script

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def session(program: str, world=None):
    checked, fsm = load_program(program)
    from hila_lang.worlds.scripted.world import ScriptedWorld

    world = world or ScriptedWorld()
    home = getattr(world, "home", None)
    return Interpreter(checked, fsm, world, DryBackend(home if home is not None else (0, 0, 0)))


def feed(interp: Interpreter, *commands: str) -> str:
    out = io.StringIO()
    repl = Repl(interp, stdin=io.StringIO("".join(c + "\n" for c in commands)), stdout=out)
    repl.cmdloop()
    return out.getvalue()


def test_step_by_step_through_abc():
    interp = session("programs/abc.hila")
    expected = ["main/b", "main/a#1", "main/a#2", "main/c#2", "end"]
    for name in expected:
        out = feed(interp, "step")
        assert interp.current == name
        assert out.rstrip().endswith(f"at {name}") or (name == "end" and "at end" in out)
    out = feed(interp, "step")
    assert interp.done and out.rstrip().endswith("finished")
    out = feed(interp, "step")
    assert "the program has finished; 'reset' to run it again" in out
    feed(interp, "reset")
    assert interp.current == "main/c#1" and not interp.done and interp.trace == []


def test_transcript_break_continue_where_icps_path(tmp_path):
    interp = session("programs/reach_return.hila")
    png = tmp_path / "last.png"
    out = feed(interp, "break main/visit#2/back", "run", "where", "icps", "step", "path --plot " + str(png),
               "continue", "quit")
    lines = out.splitlines()
    assert "(hila) break main/visit#2/back" in lines
    assert "breakpoint: main/visit#2/back" in lines
    assert "at main/visit#2/back (run): run reach.back(object = {main/visit#2:thing}, home = home) pen up" in lines
    assert "  object       = (0.360, -0.020, 0.600)" in lines  # icps of the state about to run
    assert any(line.startswith("main/visit#2/back: 35 points") for line in lines)
    assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert interp.done and lines[-2] == "finished"  # continue ran to the end; then quit
    import cv2

    img = cv2.imread(str(png))
    assert img is not None and img.shape[0] > 300 and (img < 250).any()


def test_errors_are_reported_and_the_session_goes_on():
    interp = session("programs/abc.hila")
    out = feed(interp, "stpe", "step x", "break nowhere", "path", "step", "quit")
    assert "error: unknown command 'stpe'; did you mean 'step'?" in out
    assert "error: expected 'step' or 'step N' with a whole number N, got 'x'" in out
    assert "error: no state matches 'nowhere'" in out
    assert "no path yet: no run state has run" in out
    assert interp.current == "main/b"  # the later 'step' still ran
    out = feed(interp, "path --plot", "quit")
    assert "error: usage: path [--plot FILE.png]" in out and "points" not in out  # refused before printing


def test_runtime_error_keeps_the_session(tmp_path):
    prog = tmp_path / "p.hila"
    prog.write_text("import reach\nmain {\n  run reach.reach(object = shelf.top, home = hand)\n}\n")
    interp = session(str(prog))
    out = feed(interp, "step", "where", "quit")
    assert "error: unknown scene point 'shelf.top' (in state main/reach)" in out
    assert "at main/reach (run)" in out
    assert interp.current == "main/reach"


def test_fsm_marks_the_current_state_and_vars():
    interp = session("tests/programs/game_sample.hila", load_script("tests/programs/game_sample.world.yaml"))
    out = feed(interp, "step 3", "fsm", "vars")
    assert interp.current == "main/mark/reach"
    assert "> main/mark/reach" in out
    assert '  main:c = "board.cell5"' in out
    out = feed(interp, "step 3")
    assert interp.current == "main/wait#1"
    out = feed(interp, "step")
    assert interp.current == "main/until#1" and "wait opponent_moved -> 3" in out


def test_hila_repl_reads_piped_stdin():
    script = "step 2\nwhere\nquit\n"
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "repl", "programs/abc.hila"], input=script,
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "(hila) step 2" in proc.stdout
    assert "at main/a#1" in proc.stdout
    assert "Traceback" not in proc.stderr
