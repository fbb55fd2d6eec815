"""The engine is bounded and interruptible (issue 13).

A step limit with a clear message, a trace that keeps memory flat, failed and interrupted steps
recorded, Ctrl-C that stops the current step and leaves the session (world, simulator, hand)
intact -- in the REPL under a real terminal (pty) too -- and exit status 130 for ``hila exec``.
"""

from __future__ import annotations

import os
import pty
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from hila_lang import cli
from hila_lang.core.errors import Interrupted, StepLimitError
from hila_lang.language import load_program
from hila_lang.engine.interpreter import Interpreter
from hila_lang.language.limits import DEFAULT_STEP_LIMIT, TRACE_KEEP
from hila_lang.robot.dry import DryBackend
from hila_lang.worlds.scripted.world import ScriptedWorld

ROOT = Path(__file__).resolve().parent.parent
LOOP = "main { while true { let x = 1 } }\n"
HILA = [sys.executable, "-m", "hila_lang"]


def engine(tmp_path, text: str, world=None, **kwargs) -> Interpreter:
    prog = tmp_path / "p.hila"
    prog.write_text(text)
    checked, fsm = load_program(prog)
    return Interpreter(checked, fsm, world or ScriptedWorld(), DryBackend((0.2, -0.25, 0.75)), **kwargs)


# --------------------------------------------------------------------------- bounded


def test_the_step_limit_stops_a_loop_that_never_ends(tmp_path):
    interp = engine(tmp_path, LOOP, step_limit=1000)
    with pytest.raises(StepLimitError) as info:
        interp.run()
    assert str(info.value).splitlines() == [
        f"{tmp_path / 'p.hila'}:1:8: error: stopped after 1000 steps without finishing (the step limit) "
        "(in state main/while#1)",
        "    main { while true { let x = 1 } }", "           ^",
        "hint: a loop that never ends? raise the limit with --max-steps N (0 for none)"]
    assert info.value.exit_code == 1 and interp.trace.total == 1000
    interp.run(max_steps=10)  # a caller's own budget stops quietly, and the session goes on
    assert interp.trace.total == 1010
    assert DEFAULT_STEP_LIMIT == 100_000


def test_exec_stops_at_the_limit_with_exit_1_and_max_steps_moves_it(tmp_path, capsys):
    prog = tmp_path / "loop.hila"
    prog.write_text(LOOP)
    assert cli.main(["exec", str(prog), "--quiet", "--max-steps", "300"]) == 1
    assert "stopped after 300 steps without finishing (the step limit)" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        cli.main(["exec", str(prog), "--max-steps", "-1"])
    assert info.value.code == 2 and "expected a whole number >= 0 (0: no limit), got -1" in capsys.readouterr().err


def test_explain_and_repl_keep_to_max_steps_too(tmp_path, capsys, monkeypatch):
    """Every run command takes --max-steps; explain and the REPL used to ignore it."""
    import io

    prog = tmp_path / "loop.hila"
    prog.write_text(LOOP)
    assert cli.main(["explain", str(prog), "--max-steps", "300"]) == 1
    assert "stopped after 300 steps without finishing (the step limit)" in capsys.readouterr().err
    monkeypatch.setattr("sys.stdin", io.StringIO("run\nquit\n"))
    cli.main(["repl", str(prog), "--max-steps", "40"])
    assert "stopped after 40 steps without finishing (the step limit)" in "".join(capsys.readouterr())


def test_the_trace_in_memory_is_bounded_and_counts_everything(tmp_path):
    interp = engine(tmp_path, LOOP, step_limit=None)
    seen = []
    interp.observers.append(lambda entry: seen.append(entry.step))
    interp.run(max_steps=5 * TRACE_KEEP)
    assert len(interp.trace) == interp.trace.total == 5 * TRACE_KEEP and seen == list(range(1, 5 * TRACE_KEEP + 1))
    kept = list(interp.trace)
    assert TRACE_KEEP <= len(kept) < 2 * TRACE_KEEP
    assert kept[-1].step == 5 * TRACE_KEEP and [e.step for e in kept] == list(range(kept[0].step, 5 * TRACE_KEEP + 1))
    assert interp.trace.kinds == {"branch": 5 * TRACE_KEEP // 2, "set": 5 * TRACE_KEEP // 2}


def test_runs_keep_memory_flat_in_the_back_end_and_the_world(tmp_path, monkeypatch):
    world = ScriptedWorld()
    text = "import reach\nmain { repeat 2500 { run reach.reach(object = (0.3, -0.1, 0.6), home = hand) } }\n"
    monkeypatch.chdir(ROOT)
    interp = engine(tmp_path, text, world, step_limit=None)
    interp.run(max_steps=3 * TRACE_KEEP)
    assert len(list(interp.backend.moves)) < 2000 and len(list(world.log)) < 2000  # kept
    assert len(interp.backend.moves) == len(world.log) == 1000  # 1000 run states, counted
    assert world.finish(interp.trace)["states"] == 3 * TRACE_KEEP  # counted, not just the kept ones


def test_memory_stays_flat_to_the_default_step_limit(tmp_path):
    """The issue's input: ``while true { let x = 1 }`` until the default step limit, <= 300 MB
    (the process's own peak, VmHWM, read by itself at the end: ``ru_maxrss`` would count the
    pages of the pytest process it was forked from)."""
    prog = tmp_path / "loop.hila"
    prog.write_text(LOOP)
    trace = tmp_path / "t.txt"
    code = ("import sys\nfrom hila_lang import cli\n"
            f"status = cli.main(['exec', {str(prog)!r}, '--quiet', '--trace', {str(trace)!r}])\n"
            "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0].split()[1]\n"
            "print('peak', hwm, file=sys.stderr)\n"
            "sys.exit(status)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    peak_mb = int(out.stderr.split("peak ")[1].split()[0]) / 1024  # kB
    assert out.returncode == 1 and "stopped after 100000 steps" in out.stderr
    assert peak_mb <= 300, f"peak {peak_mb:.0f} MB"
    assert sum(1 for _ in trace.open()) == DEFAULT_STEP_LIMIT  # every step streamed to the file


def test_a_bounded_log_counts_everything_and_cuts_its_end_like_a_list():
    from hila_lang.core.bounded import BoundedLog

    log = BoundedLog(3)
    log.extend(range(10))
    kept = list(log)
    assert len(log) == 10 and 3 <= len(kept) < 6 and kept == list(range(10))[-len(kept):]
    assert log[-1] == 9 and log.dropped == 10 - len(kept)
    saved = len(log)  # a snapshot keeps the length ...
    log.append(10)
    log.append(11)
    del log[saved:]  # ... and going back cuts the log to it
    now = list(log)
    assert len(log) == 10 and now and now == list(range(10))[-len(now):]  # the newest of what is left
    del log[8:]  # the items appended after the 8th go, kept or not
    now = list(log)
    assert len(log) == 8 and now == list(range(8))[len(range(8)) - len(now):]
    with pytest.raises(TypeError):
        del log[0]
    everything = BoundedLog(0, range(5000))
    assert len(everything) == 5000 and list(everything)[0] == 0


# --------------------------------------------------------------------------- failed steps are recorded


def test_the_trace_of_a_failed_run_ends_with_the_failing_state(tmp_path, capsys):
    """The issue's input: ``echo old > t.txt; hila exec P --trace t.txt`` where P fails at run time."""
    prog = tmp_path / "p.hila"
    prog.write_text("main { let x = 1\n let y = 1 / 0 }\n")
    trace = tmp_path / "t.txt"
    trace.write_text("old\n")
    assert cli.main(["exec", str(prog), "--trace", str(trace), "--quiet"]) == 1
    assert trace.read_text().splitlines() == [
        "  1  main/let#1  [line 1]  set x = 1",
        "  2  main/let#2  [line 2]  failed: division by zero in '1 / 0'"]
    assert "division by zero in '1 / 0' (in state main/let#2)" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.hila", "t.txt"]  # no temporary file left


def test_a_bad_trace_path_is_refused_before_the_run(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    code = cli.main(["exec", str(ROOT / "programs" / "abc.hila"), "--trace", str(tmp_path / "afile" / "t.txt")])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == ""
    assert captured.err == f"{tmp_path / 'afile' / 't.txt'}: error: cannot make its folder: {tmp_path / 'afile'} is a file\n"


# --------------------------------------------------------------------------- Ctrl-C


class Stopper(ScriptedWorld):
    """A scripted world whose question 'slow' is where Ctrl-C comes (once), and whose notify
    sends a real SIGINT to this process (the step has started changing the world by then)."""

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        self.interrupt_query = True
        self.signal_in_notify = False

    def query(self, name, *args):
        if name == "slow" and self.interrupt_query:
            self.interrupt_query = False
            raise KeyboardInterrupt
        return super().query(name, *args)

    def notify(self, event, **data):
        super().notify(event, **data)
        if self.signal_in_notify and event == "state_done":
            self.signal_in_notify = False
            os.kill(os.getpid(), signal.SIGINT)


def test_ctrl_c_inside_a_step_leaves_the_state_to_run_again(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    world = Stopper(answers={"slow": 2})
    interp = engine(tmp_path, "import reach\nmain { let n = ask slow\n run reach.reach(object = (0.3, -0.1, 0.6), home = hand) }\n", world)
    with pytest.raises(Interrupted) as info:
        interp.step()
    assert info.value.exit_code == 130 and info.value.state == "main/let#1"
    assert info.value.message == "interrupted (Ctrl-C) before this state finished"
    assert interp.current == "main/let#1" and interp.env == {} and not interp.done  # nothing happened
    assert interp.trace[-1].text == "interrupted" and interp.trace[-1].error
    interp.step()  # the session goes on: the same state runs again
    assert interp.current == "main/reach" and list(interp.env.values()) == [2]


def test_ctrl_c_once_the_world_is_told_waits_until_the_step_is_recorded(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    world = Stopper(answers={"slow": 2})
    world.interrupt_query = False
    interp = engine(tmp_path, "import reach\nmain { run reach.reach(object = (0.3, -0.1, 0.6), home = hand)\n let x = 1 }\n", world)
    world.signal_in_notify = True
    with pytest.raises(Interrupted, match="just after this state"):
        interp.step()
    assert interp.current == "main/let#1"  # the run state was recorded whole: the world knows it ran
    assert [e for e, _ in world.log] == ["state_done"] and interp.trace[-1].state == "main/reach"
    np.testing.assert_allclose(interp.hand(), interp.trace[-1].path[-1])


def _sigint_after(delay: float, argv, **kwargs):
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, **kwargs)
    time.sleep(delay)
    sent = time.monotonic()
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal does: the whole process group
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # pragma: no cover - the failure this guards against
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"{argv} hung after SIGINT")
    return proc.returncode, out, err, time.monotonic() - sent


def test_exec_interrupted_exits_130_and_keeps_its_trace(tmp_path):
    prog = tmp_path / "loop.hila"
    prog.write_text(LOOP)
    trace = tmp_path / "t.txt"
    code, _, err, took = _sigint_after(3.0, [*HILA, "exec", str(prog), "--quiet", "--max-steps", "0",
                                             "--trace", str(trace)], cwd=tmp_path)
    assert code == 130 and took < 10 and "Traceback" not in err
    assert "interrupted (Ctrl-C)" in err
    lines = trace.read_text().splitlines()
    assert len(lines) > 10 and lines[-1].split()[0] == str(len(lines))  # every step, numbered, to the last


def _read_until(fd: int, marker: bytes, timeout: float = 60.0) -> str:
    buf, end = b"", time.monotonic() + timeout
    while time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            try:
                chunk = os.read(fd, 65536)
            except OSError:
                break
            buf += chunk
            if buf.rstrip().endswith(marker):
                return buf.decode(errors="replace")
    raise AssertionError(f"no {marker!r} within {timeout} s; got ...{buf[-500:]!r}")


def test_repl_under_a_terminal_survives_ctrl_c(tmp_path):
    """``hila repl`` on ``while true``: run, Ctrl-C, where, step -- the session goes on; Ctrl-C at
    the idle prompt does not end it either; quit leaves with status 0."""
    prog = tmp_path / "loop.hila"
    prog.write_text(LOOP)
    pid, fd = pty.fork()
    if pid == 0:  # the child: hila on the pty as its terminal
        os.chdir(tmp_path)
        os.environ["HOME"] = str(tmp_path)  # readline's history file
        os.execv(sys.executable, [*HILA, "repl", str(prog), "--max-steps", "0"])
    try:
        _read_until(fd, b"(hila)")
        os.write(fd, b"run\n")
        time.sleep(2.0)
        os.write(fd, b"\x03")  # Ctrl-C: the terminal sends SIGINT to hila
        out = _read_until(fd, b"(hila)")
        assert "interrupted" in out and "Traceback" not in out
        os.write(fd, b"where\n")
        where = _read_until(fd, b"(hila)")
        steps = int(where.split("step ")[1].split(",")[0])
        assert steps > 10 and "hand at (0.310, -0.090, 0.671)" in where and "at main/" in where  # the ready point
        os.write(fd, b"step\n")
        after = _read_until(fd, b"(hila)")
        assert f"{steps + 1:>3}  main/" in after  # the next step, numbered on from where it stopped
        time.sleep(0.5)  # let readline settle in its wait for input (a signal just before it waits
        os.write(fd, b"\x03")  # is seen only with the next key: CPython's readline) -- at the idle prompt
        try:
            idle = _read_until(fd, b"(hila)", timeout=5.0)
        except AssertionError:
            os.write(fd, b"\n")  # the key that lets readline see it
            idle = _read_until(fd, b"(hila)")
        assert "interrupted: type 'quit' to leave" in idle
        os.write(fd, b"quit\n")
        _, status = os.waitpid(pid, 0)
        assert os.waitstatus_to_exitcode(status) == 0
    finally:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        os.close(fd)
