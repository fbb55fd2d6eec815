"""Hot reload and going back in the REPL.

A transcript drives ``hila repl`` through a pipe and edits the program and its template between
commands: ``reload`` goes on from the same state with the new behaviour, a broken edit keeps the
old program, ``back 2`` then ``step 2`` reproduce the same trace entries.  Going back restores the
world and the back end: the dry one, the PyBullet simulator, and a tic-tac-toe game's board and
opponent.
"""

from __future__ import annotations

import io
import queue
import re
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from hila_lang.core.errors import HilaRuntimeError
from hila_lang.language import load_program
from hila_lang.engine.history import resume_at
from hila_lang.engine.interpreter import Interpreter
from hila_lang.session.repl import Repl
from hila_lang.plugins.options import RunOptions
from hila_lang.robot.dry import DryBackend
from hila_lang.worlds.scripted.world import ScriptedWorld

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = """\
import reach
point home = (0.18, -0.25, 0.75)
point cup = (0.30, -0.18, 0.60)
point box = (0.36, -0.02, 0.60)
hand at home

main {
    run reach.reach(object = cup, home = home)
    run reach.back(object = cup, home = home)
    run reach.reach(object = cup, home = home)
    run reach.back(object = cup, home = home)
}
"""


class Session:
    """``hila repl`` on a pipe: send a command, read its output up to a line matching ``until``."""

    def __init__(self, *args: str, cwd: Path) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "hila_lang", "repl", *args], cwd=cwd, text=True,
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        self.lines: queue.Queue = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.read(r"^at ")

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line.rstrip("\n"))
        self.lines.put(None)

    def read(self, until: str) -> list[str]:
        got = []
        while True:
            line = self.lines.get(timeout=60)
            assert line is not None, "the REPL ended early:\n" + "\n".join(got)
            got.append(line)
            if re.search(until, line):
                return got

    def send(self, command: str, until: str) -> list[str]:
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()
        return self.read(until)

    def close(self) -> int:
        self.proc.stdin.write("quit\n")
        self.proc.stdin.close()
        return self.proc.wait(timeout=60)


def entries(lines: list[str]) -> list[str]:
    return [line for line in lines if re.match(r"^\s+\d+  main/", line)]


def test_transcript_reload_goes_on_with_the_new_program_and_back_reproduces(tmp_path):
    prog = tmp_path / "task.hila"
    prog.write_text(PROGRAM)
    template = tmp_path / "reach.yaml"  # found beside the program, edited by hand below
    shutil.copy(ROOT / "primitives" / "reach.yaml", template)
    s = Session(str(prog), cwd=tmp_path)
    try:
        first = entries(s.send("step 2", r"^at "))
        assert [e.split()[1] for e in first] == ["main/reach#1", "main/back#1"]

        # edit: the second reach goes to the box now
        prog.write_text(PROGRAM.replace("    run reach.reach(object = cup, home = home)\n    run reach.back(object = cup, home = home)\n}",
                                        "    run reach.reach(object = box, home = home)\n    run reach.back(object = box, home = home)\n}"))
        out = s.send("reload", r"^reloaded|reload failed")
        assert out[-1].startswith(f"reloaded {prog} (5 states; templates {template}); resuming at main/reach#2 "
                                  "(the same state)")
        new = entries(s.send("step", r"^at "))
        assert new[0].split()[1] == "main/reach#2" and "object=(0.360, -0.020, 0.600)" in new[0]

        # a broken edit: located error, the old program keeps running
        prog.write_text(PROGRAM.replace("main {", "main {\n    run reach.reach(object = cup,"))
        out = s.send("reload", r"^reload failed")
        assert out[0] == "(hila) reload"
        assert re.match(rf"^{re.escape(str(prog))}:\d+:\d+: error: unexpected ", out[1]), out
        assert out[-1] == "reload failed: the program as it was keeps running (at main/back#2)"
        kept = entries(s.send("step", r"^at |^finished"))
        assert kept[0].split()[1] == "main/back#2" and "object=(0.360, -0.020, 0.600)" in kept[0]

        # back 2 then step 2: the same trace entries again
        out = s.send("back 2", r"^back 2 steps")
        assert out[-1].startswith("back 2 steps: at main/reach#2; hand at (0.180, -0.250, 0.750)")
        again = entries(s.send("step 2", r"^at |^finished"))
        assert again == new + kept

        # the template edited by hand: a tag renamed, a segment boundary moved
        boxed = PROGRAM.replace("    run reach.reach(object = cup, home = home)\n    run reach.back(object = cup, home = home)\n}",
                                "    run reach.reach(object = box, home = home)\n    run reach.back(object = box, home = home)\n}")
        prog.write_text(boxed)
        text = template.read_text()
        text = text.replace("- {tag: reach, start: 0, stop: 36, contact: false}",
                            "- {tag: go, start: 0, stop: 30, contact: false}")
        text = text.replace("- {tag: back, start: 36, stop: 71, contact: false}",
                            "- {tag: back, start: 30, stop: 71, contact: false}")
        template.write_text(text)
        out = s.send("reload", r"^reloaded|reload failed")
        assert "error: template 'reach' has no sub-template 'reach'" in "\n".join(out)  # the program says reach
        prog.write_text(boxed.replace("reach.reach", "reach.go"))
        out = s.send("reload", r"^reloaded|reload failed")
        assert out[-1].endswith("resuming at end (the same state)")
        out = s.send("back 2", r"^back 2 steps")
        assert out[-1].startswith("back 2 steps: at main/go#2 (state main/reach#2 is not in the program; "
                                  "main/go#2 is written where it was (line 10))"), out
        moved = entries(s.send("step 2", r"^at |^finished"))
        assert moved[0].split()[1] == "main/go#2" and " 30 points " in moved[0]  # the moved boundary
        assert moved[1].split()[1] == "main/back#2" and " 41 points " in moved[1]
        assert s.close() == 0
    finally:
        if s.proc.poll() is None:
            s.proc.kill()


def session(program: str, text: str | None = None, world=None, backend=None) -> Interpreter:
    checked, fsm = load_program(program, text)
    return Interpreter(checked, fsm, world or ScriptedWorld(), backend or DryBackend((0.18, -0.25, 0.75)))


def test_resume_at_the_same_state_or_the_first_one_after_it_that_remains(tmp_path):
    prog = tmp_path / "p.hila"
    old = load_program(str(prog), PROGRAM)[1]
    new = load_program(str(prog), PROGRAM.replace("    run reach.back(object = cup, home = home)\n    run reach.reach",
                                                  "    run reach.reach"))[1]
    assert resume_at(old, old, "main/back#1") == ("main/back#1", None)
    name, why = resume_at(old, new, "main/back#2")  # back#2 is now plain 'back'; reach#2 is 'reach'
    assert name == "end" and why.startswith("state main/back#2 is no longer in the program; end is the first")
    name, why = resume_at(old, new, "main/back#1")  # deleted: the next statement moved up into its line
    assert (name, why) == ("main/reach#2", "state main/back#1 is not in the program; main/reach#2 is written "
                                           "where it was (line 9)")
    assert resume_at(old, load_program(str(prog), "import reach\nmain { }\n")[1], "main/back#1")[0] == "end"


def test_reload_refuses_another_world_and_says_why(tmp_path):
    interp = session(str(tmp_path / "p.hila"), PROGRAM)
    checked, fsm = load_program(str(tmp_path / "p.hila"), "world letters\n" + PROGRAM)
    with pytest.raises(HilaRuntimeError, match="the program now names world 'letters', not 'scripted'"):
        interp.reload(checked, fsm)
    assert interp.fsm.world == "scripted"


def test_back_on_pybullet_restores_the_simulator_and_the_same_steps_follow():
    from hila_lang.robot.backend import PyBulletBackend

    backend = PyBulletBackend()
    try:
        interp = session("programs/reach_return.hila", backend=backend)
        interp.keep_history()
        q0 = backend.body.arm_angles()
        first = [interp.step() for _ in range(3)]
        assert interp.back(3).startswith("back 3 steps: at main/visit#1")
        assert np.abs(backend.body.arm_angles() - q0).max() < 1e-12  # the joints are as they were
        assert len(backend.traces) == 0
        again = [interp.step() for _ in range(3)]
        assert [e.text for e in again] == [e.text for e in first]
        for a, b in zip(first, again):
            if a.kind == "run":
                assert a.executed.shape == b.executed.shape
                assert np.abs(a.executed - b.executed).max() < 1e-9
    finally:
        backend.close()


def test_back_restores_a_tictactoe_game_board_and_opponent(tmp_path):
    from hila_lang.worlds.tictactoe.world import TicTacToeWorld

    options = RunOptions(seed=3, out=tmp_path, stdin=io.StringIO(), stdout=io.StringIO())
    world = TicTacToeWorld(options, {"opponent": "random", "report": False})
    backend = DryBackend()
    world.attach(backend)
    checked, fsm = load_program(str(ROOT / "programs" / "game.hila"))
    interp = Interpreter(checked, fsm, world, backend)
    interp.keep_history()
    interp.run(max_steps=12)
    board, moves = world.board, list(world.moves)
    later = interp.run(max_steps=10)
    assert world.board != board
    interp.back(10)
    assert world.board == board and world.moves == moves
    assert [e.text for e in interp.run(max_steps=10)] == [e.text for e in later]  # the same opponent moves


def test_back_without_snapshots_says_which_plugin_cannot(tmp_path):
    world = ScriptedWorld()
    world.snapshots = None
    interp = session(str(tmp_path / "p.hila"), PROGRAM, world=world)
    out = io.StringIO()
    Repl(interp, stdin=io.StringIO("step\nback\nquit\n"), stdout=out).cmdloop()
    assert "error: the world 'scripted' cannot go back (no snapshots capability)" in out.getvalue()


def test_back_limits_and_reset(tmp_path):
    interp = session(str(tmp_path / "p.hila"), PROGRAM)
    interp.keep_history(limit=2)
    with pytest.raises(HilaRuntimeError, match="nothing to go back to"):
        interp.back()
    interp.run(max_steps=3)
    with pytest.raises(HilaRuntimeError, match=r"can go back 1 to 2 step\(s\), not 3"):
        interp.back(3)
    interp.reset()
    with pytest.raises(HilaRuntimeError, match="nothing to go back to"):
        interp.back()
