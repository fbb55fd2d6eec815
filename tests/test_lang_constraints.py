"""``via`` and ``avoid`` in the language: parsed, checked, compiled (a task call's constraints reach
every run inside), executed on both back ends through OSILA's plan adjustment, and explained.

The route is measured here, independently of the code under test: a forced waypoint is met when a
route waypoint lies within OSILA's threshold of it; an obstacle is cleared when the polyline
through the route (sampled every 0.1 mm) stays outside its sphere.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from hila_lang.core.errors import CheckError, ConstraintError, HilaRuntimeError
from hila_lang.language import load_program
from hila_lang.language.checker import check
from hila_lang.language.compiler import compile_program
from hila_lang.language.fsm import FSM
from hila_lang.engine.interpreter import Interpreter
from hila_lang.language.transformer import parse_program
from hila_lang.robot.dry import DryBackend
from hila_lang.worlds.scripted.world import ScriptedWorld

ROOT = Path(__file__).resolve().parent.parent
PROGRAM = "tests/programs/constraints.hila"
VIA = np.array([0.211, -0.224, 0.735])
LAMP = np.array([0.211, -0.219, 0.735])


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def front_end(src: str, file: str = "t.hila"):
    return compile_program(check(parse_program(textwrap.dedent(src).lstrip("\n"), file)))


def nearest(path: np.ndarray, point: np.ndarray) -> float:
    return float(np.linalg.norm(path - point, axis=1).min())


def clearance(path: np.ndarray, centre: np.ndarray) -> float:
    """Smallest distance from ``centre`` to the polyline through ``path``, sampled every 0.1 mm."""
    samples = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        n = max(int(np.linalg.norm(b - a) / 1e-4), 1)
        samples.append(a + np.linspace(0, 1, n + 1)[1:, None] * (b - a))
    return float(np.linalg.norm(np.vstack(samples) - centre, axis=1).min())


def run(program: str, world=None, backend=None):
    checked, fsm = load_program(program)
    world = world or ScriptedWorld()
    interp = Interpreter(checked, fsm, world, backend or DryBackend())
    return interp, interp.run()


# ----------------------------------------------------------------------------- front end

def test_constraints_parse_on_runs_and_calls_and_compile_into_every_run_inside():
    fsm = front_end("""
        import reach
        point lamp = (0.2, -0.2, 0.7)
        task visit(thing) {
            run reach.reach(object = thing, home = hand) via (0.21, -0.22, 0.73)
        }
        main {
            visit(lamp) avoid lamp radius 0.02 avoid thing.top radius 0.01
        }
    """)
    reach = fsm.states["main/visit/reach"]
    # the call's constraints first (resolved in the caller), then the run's own
    assert [c.text() for c in reach.constraints] == [
        "avoid lamp radius 0.02", "avoid thing.top radius 0.01", "via (0.21, -0.22, 0.73)"]
    assert [(c.pos.line, c.pos.column) for c in reach.constraints] == [(7, 17), (7, 40), (4, 50)]
    assert "avoid lamp radius 0.02 avoid thing.top radius 0.01 via (0.21, -0.22, 0.73)" in reach.describe()
    again = FSM.from_dict(fsm.to_dict())
    assert again == fsm
    assert [(c.kind, c.text(), c.pos.line) for c in again.states["main/visit/reach"].constraints] == [
        (c.kind, c.text(), c.pos.line) for c in reach.constraints]


def test_a_run_without_constraints_dumps_as_before():
    fsm = front_end("import reach\nmain { run reach.reach(object = (0.3, 0, 0.6), home = hand) }\n")
    assert "constraints" not in fsm.to_dict()["states"][0]


@pytest.mark.parametrize("src, message", [
    ("main { run reach.reach(object = hand, home = hand) via hand radius 0.02 }",
     "t.hila:2:68: error: a 'via' waypoint takes no radius"),
    ("main { run reach.reach(object = hand, home = hand) avoid hand }",
     "t.hila:2:52: error: 'avoid' needs a radius: avoid POINT radius R (metres)"),
    ("main { run reach.reach(object = hand, home = hand) avoid hand radius 0 }",
     "t.hila:2:70: error: an obstacle's radius must be more than 0 metres, got 0"),
    ("main { run reach.reach(object = hand, home = hand) via 3 }",
     "t.hila:2:56: error: 'via' needs a point or a point group, got 3"),
    ("main { run reach.reach(object = hand, home = hand) via lmap }",
     "t.hila:2:56: error: unknown name 'lmap'"),
    ("main { run reach.reach(object = hand, home = hand) via (0.3, 0.1) }",
     "t.hila:2:56: error: 'via' needs a point of the world (x, y, z), got the 2-D point (0.3, 0.1)"),
    ("main { run reach.reach(object = hand, home = hand) via \"abc\" }",
     "t.hila:2:56: error: 'via' needs a point or a point group, got \"abc\""),
    ("main { run reach.reach(object = hand, home = hand) avoid lamp radius \"x\" }",
     "t.hila:2:70: error: an obstacle's radius must be a number of metres, got \"x\""),
    ("main { run reach.reach(object = hand, home = hand) avoid lamp radius none }",
     "t.hila:2:70: error: an obstacle's radius must be a number of metres, got none"),
])
def test_constraint_mistakes_are_located_check_errors(src, message):
    with pytest.raises(CheckError) as info:
        front_end("import reach\npoint lamp = (0.2, -0.2, 0.7)\n" + src)
    text = str(info.value).replace("t.hila:3:", "t.hila:2:")  # the point line shifts the source by one
    assert text.startswith(message), text


# ----------------------------------------------------------------------------- running

def test_the_route_meets_each_constraint_and_would_not_without_them():
    interp, trace = run(PROGRAM)
    runs = {t.state: t for t in trace if t.kind == "run"}
    threshold = runs["main/reach"].step_result.result.threshold
    assert nearest(runs["main/reach"].path, VIA) <= threshold
    assert clearance(runs["main/back"].path, LAMP) >= 0.012
    assert clearance(runs["main/visit/reach"].path, LAMP) >= 0.015
    assert clearance(runs["main/visit/back"].path, LAMP) >= 0.015
    # the same program without via/avoid misses the waypoint and enters the obstacle: the
    # constraints changed the route
    bare = Path(PROGRAM).read_text().replace(" via (0.211, -0.224, 0.735)", "")
    bare = bare.replace(" avoid lamp radius 0.012", "").replace(" avoid lamp radius 0.015", "")
    checked, fsm = load_program(PROGRAM, bare)
    free = {t.state: t for t in Interpreter(checked, fsm, ScriptedWorld(), DryBackend()).run() if t.kind == "run"}
    assert nearest(free["main/reach"].path, VIA) > threshold
    assert clearance(free["main/back"].path, LAMP) < 0.012
    assert clearance(free["main/visit/reach"].path, LAMP) < 0.015


def test_the_trace_says_how_each_constraint_was_met():
    _, trace = run(PROGRAM)
    reach = trace[0].text
    assert reach.endswith(f"; via (0.211, -0.224, 0.735) at 16:48 met at "
                          f"{nearest(trace[0].path, VIA) * 1000:.1f} mm")
    assert trace[4].text.endswith(f"; avoid lamp radius 0.015 at 18:16 cleared by "
                                  f"{(clearance(trace[4].path, LAMP) - 0.015) * 1000:.1f} mm")


def test_the_trace_measures_where_the_hand_went_not_the_plan():
    class Shaky(DryBackend):  # the arm ends every move 3 mm off the plan along x
        def move(self, path, **kw):
            return super().move(path, **kw) + np.array([0.003, 0.0, 0.0])

    _, trace = run(PROGRAM, backend=Shaky())
    reach = trace[0]
    went = nearest(reach.executed, VIA) * 1000
    assert abs(went - nearest(reach.path, VIA) * 1000) > 0.5  # the two differ here
    assert reach.text.endswith(f"met at {went:.1f} mm")


def test_on_the_pybullet_back_end_the_executed_route_meets_them_too():
    from hila_lang.robot.backend import PyBulletBackend

    backend = PyBulletBackend()
    try:
        checked, fsm = load_program(PROGRAM)
        interp = Interpreter(checked, fsm, ScriptedWorld(), backend)
        backend.reset_hand(np.array([0.18, -0.25, 0.75]))
        trace = interp.run()
    finally:
        backend.close()
    runs = {t.state: t for t in trace if t.kind == "run"}
    threshold = runs["main/reach"].step_result.result.threshold
    assert nearest(runs["main/reach"].executed, VIA) <= threshold + 0.0005  # tracking: well under 0.5 mm
    assert clearance(runs["main/back"].executed, LAMP) >= 0.012 - 0.0005
    assert clearance(runs["main/visit/back"].executed, LAMP) >= 0.015 - 0.0005


def test_a_point_group_is_one_obstacle_per_point_and_values_come_from_ask():
    world = ScriptedWorld(points={"shelf.top.a": LAMP, "shelf.top.b": LAMP + [0.0, 0.0, -0.05]},
                          answers={"clearance": 0.012, "waypoint": [[0.211, -0.224, 0.735]]})
    prog = ROOT / "tests" / "programs" / "_group.hila"
    src = ("import reach\nhand at (0.18, -0.25, 0.75)\nmain {\n"
           "  run reach.reach(object = (0.30, -0.18, 0.60), home = (0.18, -0.25, 0.75)) via ask waypoint\n"
           "  run reach.back(object = (0.30, -0.18, 0.60), home = (0.18, -0.25, 0.75)) avoid shelf.top radius ask clearance\n}\n")
    checked, fsm = load_program(str(prog), src)
    trace = Interpreter(checked, fsm, world, DryBackend()).run()
    back = trace[1]
    assert [c.name for c in back.step_result.constraints] == [
        "avoid shelf.top radius ask clearance at 5:76 (shelf.top.a)",
        "avoid shelf.top radius ask clearance at 5:76 (shelf.top.b)"]
    assert clearance(back.path, LAMP) >= 0.012 and clearance(back.path, LAMP + [0, 0, -0.05]) >= 0.012
    assert nearest(trace[0].path, VIA) <= trace[0].step_result.result.threshold


CONTRADICTION = """\
import reach
point lamp = (0.211, -0.219, 0.735)
hand at (0.18, -0.25, 0.75)
main {
    run reach.reach(object = (0.30, -0.18, 0.60), home = (0.18, -0.25, 0.75)) via lamp avoid lamp radius 0.02
}
"""


def test_a_contradicted_pair_is_a_located_error_naming_both(tmp_path):
    prog = tmp_path / "c.hila"
    prog.write_text(CONTRADICTION)
    checked, fsm = load_program(str(prog))
    with pytest.raises(ConstraintError) as info:
        Interpreter(checked, fsm, ScriptedWorld(), DryBackend()).run()
    text = str(info.value)
    assert text.splitlines()[0] == (
        f"{prog}:5:5: error: contradictory constraints: via lamp at 5:79 lies inside "
        "avoid lamp radius 0.02 at 5:88 deeper than the threshold 6.854e-05 (in state main/reach)")
    assert text.splitlines()[2] == "        ^"
    # the command line: exit status 1 (a run that failed), no traceback
    proc = subprocess.run([sys.executable, "-m", "hila_lang", "exec", str(prog)], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert proc.returncode == 1
    assert "contradictory constraints: via lamp at 5:79 lies inside avoid lamp radius 0.02" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_an_unmet_constraint_says_how_close_after_how_many_rounds(tmp_path):
    prog = tmp_path / "u.hila"
    prog.write_text(CONTRADICTION.replace("via lamp avoid lamp radius 0.02", "via (0.247, -0.177, 0.699)"))
    checked, fsm = load_program(str(prog))
    with pytest.raises(HilaRuntimeError) as info:  # one round of plan adjustment is not enough for it
        Interpreter(checked, fsm, ScriptedWorld(), DryBackend(), {"rounds": 1}).run()
    first = str(info.value).splitlines()[0]
    assert first.startswith(f"{prog}:5:5: error: the route could not conform after 1 round(s): "
                            "via (0.247, -0.177, 0.699) at 5:79 missed by 0.0")
    assert "(threshold 6.854e-05)" in first and first.endswith("(in state main/reach)")


# ----------------------------------------------------------------------------- explain

def test_explain_lists_pairs_map_rounds_and_why(capsys):
    from hila_lang import cli

    assert cli.main(["explain", PROGRAM, "--state", "main/reach"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "main/reach (line 16), step 1: reach.reach, 36 points"
    assert out[1] == "  ICP pairs (template -> task), 3:"
    assert out[3] == "    object       (0.340, -0.100, 0.600) -> (0.300, -0.180, 0.600)"
    assert "    home, start coincide in the template: one pair, start's, is kept" in out
    assert any(line.startswith("  map: a similarity transform (fallback): ") for line in out)
    rounds = [line for line in out if line.startswith("    round ")]
    assert rounds[-1] == f"    round {len(rounds)}: the route conforms" and len(rounds) >= 2
    for k, line in enumerate(rounds[:-1], 1):  # every round before the last says what it missed
        assert line.startswith(f"    round {k}: via (0.211, -0.224, 0.735) at 16:48 missed by ")
        assert line.endswith(f"-> round {k + 1}")
    assert not any(line.startswith("main/back") for line in out)  # --state chose one


def test_explain_of_a_failing_state_shows_each_round_then_the_error(tmp_path, capsys):
    from hila_lang import cli

    prog = tmp_path / "u.hila"
    prog.write_text(CONTRADICTION.replace("via lamp avoid lamp radius 0.02", "via (0.247, -0.177, 0.699)"))
    assert cli.main(["explain", str(prog), "--set", "osila.rounds=2"]) == 0  # two rounds meet it
    capsys.readouterr()
    assert cli.main(["explain", str(prog), "--set", "osila.rounds=1"]) == 1  # one round does not
    captured = capsys.readouterr()
    lines = captured.out.splitlines()
    assert lines[0] == "main/reach (line 5), about to run: reach.reach"
    assert "  plan adjustment: failed" in lines
    assert sum(line.startswith("    round ") for line in lines) == 1
    assert "could not conform after 1 round(s)" in captured.err


def test_repl_explain_before_and_after_a_run():
    from test_lang_repl import feed

    checked, fsm = load_program(PROGRAM)
    interp = Interpreter(checked, fsm, ScriptedWorld(), DryBackend())
    out = feed(interp, "explain", "step", "explain", "quit")
    assert "main/reach (line 16), about to run: reach.reach, 36 points" in out
    assert "main/back (line 17), about to run: reach.back, 35 points" in out
    interp2 = Interpreter(checked, fsm, ScriptedWorld(), DryBackend())
    interp2.run(max_steps=2)  # main/visit (a call) is current: explain the last run
    assert interp2.explain()[0] == "main/back (line 17), step 2: reach.back, 35 points"


def test_explain_says_how_the_threshold_was_chosen(capsys):
    """The default threshold is 2 sigma of the mapped path's position noise (``osila.noise``),
    not the 1 % of the path's size it was before: explain names the rule OSILA used."""
    from hila_lang import cli
    from hila_lang.osila.noise import NOISE_MULTIPLE

    checked, fsm = load_program(PROGRAM)
    interp = Interpreter(checked, fsm, ScriptedWorld(), DryBackend())
    explained = interp.explain()  # main/reach, about to run
    interp.run(max_steps=1)
    res = interp.last_run.step_result.result
    line = next(x for x in explained if x.startswith("  threshold: "))
    assert line == (f"  threshold: {res.threshold * 1000:.3g} mm "
                    f"(default: {NOISE_MULTIPLE:g} sigma of the mapped path's position noise)")
    assert cli.main(["explain", PROGRAM, "--state", "main/reach", "--set", "osila.threshold=0.002"]) == 0
    assert "  threshold: 2 mm (as set: osila.threshold)" in capsys.readouterr().out.splitlines()
