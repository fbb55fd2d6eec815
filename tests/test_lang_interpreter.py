"""The stepping engine over a scripted world and the dry back end: state after every step."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from hila_lang.core.errors import CheckError, HilaRuntimeError, InputError
from hila_lang.language import load_program
from hila_lang.plugins import registry
from hila_lang.plugins.options import RunOptions, parse_pairs
from hila_lang.plugins.options import split_settings
from hila_lang.robot.dry import DryBackend
from hila_lang.engine.interpreter import Interpreter
from hila_lang.worlds.scripted.world import ScriptedWorld

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def make(tmp_path, src: str, world: ScriptedWorld | None = None, start=(0.2, -0.25, 0.75)):
    prog = tmp_path / "p.hila"
    prog.write_text(textwrap.dedent(src).lstrip("\n"))
    checked, fsm = load_program(prog)
    world = world or ScriptedWorld()
    return Interpreter(checked, fsm, world, DryBackend(start)), world


GAME_LIKE = """
    import reach
    point cup = (0.30, -0.10, 0.60)
    task go(t) {
        run reach.reach(object = t, home = hand)
        run reach.back(object = t, home = none) pen down
    }
    main {
        until ask over {
            go(cup)
            wait moved
        }
    }
"""


def test_state_after_every_step(tmp_path):
    world = ScriptedWorld(answers={"over": [False, False, True]}, events={"moved": ["a", "b"]})
    interp, world = make(tmp_path, GAME_LIKE, world)
    expected = [
        ("main/until#1", "main/go"), ("main/go", "main/go/reach"), ("main/go/reach", "main/go/back"),
        ("main/go/back", "main/wait#1"), ("main/wait#1", "main/until#1"),
        ("main/until#1", "main/go"), ("main/go", "main/go/reach"), ("main/go/reach", "main/go/back"),
        ("main/go/back", "main/wait#1"), ("main/wait#1", "main/until#1"),
        ("main/until#1", "end"), ("end", None),
    ]
    for before, after in expected:
        assert interp.current == before
        entry = interp.step()
        assert entry.state == before and entry.next == after
        if after is not None:
            assert interp.current == after
    assert interp.done
    done = [d for e, d in world.log if e == "state_done"]
    assert [d["state"] for d in done] == ["main/go/reach", "main/go/back"] * 2
    assert [d["pen_down"] for d in done] == [False, True] * 2  # template contact overridden by 'pen down'
    assert world.log[-1] == ("program_done", {})


def test_hand_follows_paths_and_reach_ends_at_object(tmp_path):
    world = ScriptedWorld(answers={"over": [False, True]}, events={"moved": [1]})
    interp, _ = make(tmp_path, GAME_LIKE, world)
    interp.run(until="main/go/back")
    assert interp.current == "main/go/back"
    last = interp.trace[-1]
    np.testing.assert_allclose(last.path[0], [0.2, -0.25, 0.75], atol=1e-12)  # started at the hand
    assert np.linalg.norm(last.path[-1] - [0.30, -0.10, 0.60]) < 0.005  # reached the cup
    np.testing.assert_allclose(interp.hand(), last.path[-1])
    assert set(last.icps) == {"object", "home", "start"}


def test_run_stops_before_a_breakpoint_and_reset_restores_the_hand(tmp_path):
    src = """
        import reach
        hand at (0.18, -0.25, 0.75)
        main { repeat 3 { run reach.reach(object = (0.3, -0.1, 0.6), home = hand) } }
    """
    interp, _ = make(tmp_path, src, start=(0, 0, 0))
    np.testing.assert_allclose(interp.hand(), [0.18, -0.25, 0.75])
    interp.run(until="main/reach")
    assert interp.current == "main/reach" and len(interp.trace) == 2
    interp.run(until="main/reach")
    assert interp.current == "main/reach" and len(interp.trace) == 5
    interp.reset()
    np.testing.assert_allclose(interp.hand(), [0.18, -0.25, 0.75])
    assert interp.current == "main/repeat#1" and interp.env == {}


def test_values_and_expressions(tmp_path):
    src = """
        point a.b = (1, 2, 3)
        main {
            let p = a.b + (1, 1, 1) * 2
            let s = "cell" + 5
            let z = p.z
            let t = wait ev(z, "x")
            if t == (1, 2, 3) and not (z < 4) { wait done }
        }
    """
    world = ScriptedWorld(events={"ev": [[1, 2, 3]], "done": [None]})
    interp, _ = make(tmp_path, src, world)
    interp.run()
    env = {k.split(":")[1]: v for k, v in interp.env.items()}
    np.testing.assert_allclose(env["p"], [3, 4, 5])
    assert env["s"] == "cell5" and env["z"] == 5.0
    assert [t.state for t in interp.trace][-3:] == ["main/if#1", "main/wait#1", "end"]


def test_a_condition_must_be_boolean(tmp_path):
    interp, _ = make(tmp_path, "main { if ask n { wait e } }", ScriptedWorld(answers={"n": 3}))
    with pytest.raises(HilaRuntimeError, match=r"a condition must be true or false, got 3 from 'ask n'"):
        interp.step()


def test_script_runs_out_loudly(tmp_path):
    interp, _ = make(tmp_path, "main { while true { wait tick } }", ScriptedWorld(events={"tick": [1]}))
    interp.step(), interp.step(), interp.step()
    with pytest.raises(HilaRuntimeError, match="no more 'tick' events") as info:
        interp.step()
    assert info.value.state == "main/wait#1"


def test_plugins_resolve_lazily_and_suggest():
    assert registry.world("scripted").factory.endswith(":make_world")
    assert registry.backend("dry").name == "dry"
    with pytest.raises(InputError, match="unknown back end 'drry'") as info:
        registry.backend("drry")
    assert info.value.hint == "did you mean 'dry'?"
    assert parse_pairs(["a=1", "b = x=y"]) == {"a": "1", "b": "x=y"}
    with pytest.raises(InputError, match="expected --set KEY=VALUE"):
        parse_pairs(["oops"])


def test_the_dry_back_end_starts_at_the_worlds_home_else_its_hand_setting():
    world, dry = registry.world("scripted"), registry.backend("dry")
    w = ScriptedWorld(home=(0.1, 0.2, 0.3))
    _, _, settings = split_settings({"hand": "1,2,3"}, world, dry)
    be = dry.build(w.scene, RunOptions(), settings)
    np.testing.assert_allclose(be.hand_position(), [0.1, 0.2, 0.3])
    be = dry.build(ScriptedWorld().scene, RunOptions(), settings)  # documented --set hand=X,Y,Z
    np.testing.assert_allclose(be.hand_position(), [1, 2, 3])
    with pytest.raises(InputError, match=r"bad value for --set hand=1,2 \(back end dry\): expected X,Y,Z"):
        split_settings({"hand": "1,2"}, world, dry)


def test_a_bad_hand_at_point_names_its_line(tmp_path):
    with pytest.raises(HilaRuntimeError, match="expected a hand position of 3 finite numbers") as info:
        make(tmp_path, "hand at (1, 2)\nmain { }")
    assert info.value.line == 1 and info.value.exit_code == 1


def test_a_point_of_the_wrong_size_names_the_icp(tmp_path):
    with pytest.raises(CheckError, match=r"ICP 'object' of the 3-D template 'reach.reach' is bound to a 2-D point"):
        make(tmp_path, "import reach\nmain { run reach.reach(object = (0.3, 0), home = hand) }")
    # a size only the run knows (a world's answer) is caught when it runs
    world = ScriptedWorld(answers={"where": [[0.3, 0.0]]})
    interp, _ = make(tmp_path, "import reach\nmain { run reach.reach(object = ask where, home = hand) }", world)
    with pytest.raises(HilaRuntimeError, match=r"'reach.reach' is 3-D but ICP 'object' is bound to the 2-D point"):
        interp.step()
