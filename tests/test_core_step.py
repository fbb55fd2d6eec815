"""One HILA step: ``hila exec``, ``hila imitate`` and ``hila eval --hila`` make the same path.

Every run state of ``programs/reach_return.hila`` (the ``back`` sub-templates start where they
touched the object, so two template ICPs share the start's template point while the hand is about
a millimetre from the object: OSILA's exact pin must win there) is regenerated through
:func:`hila_lang.hierarchy.generate.generate` (what ``hila eval --hila`` calls) and through the
``hila imitate`` command with the same scene points, and must match the interpreter's path
exactly.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hila_lang.cli import main
from hila_lang.osila.demofile import read_demo_csv
from hila_lang.core.errors import InputError
from hila_lang.core.fileio import dump_yaml
from hila_lang.hierarchy.generate import generate
from hila_lang.hierarchy.step import bind, hila_step
from hila_lang.language import load_program
from hila_lang.engine.interpreter import Interpreter
from hila_lang.osila import imitate
from hila_lang.robot.dry import DryBackend
from hila_lang.osila.template import Segment, Template
from hila_lang.worlds.scripted.world import ScriptedWorld

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _in_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def _runs(program: str):
    """(template, scene binding, hand before, path) of every run state of a dry run."""
    checked, fsm = load_program(program)
    interp = Interpreter(checked, fsm, ScriptedWorld(), DryBackend((0.18, -0.25, 0.75)))
    out = []
    while not interp.done:
        st = interp.state
        before = (interp.runs.template(st), interp.runs.scene_binding(st), interp.hand()) if st.kind == "run" else None
        entry = interp.step()
        if before is not None:
            out.append((*before, entry.path, st.tag))
    return out


def test_generate_and_the_interpreter_make_the_same_step():
    runs = _runs("programs/reach_return.hila")
    assert len(runs) == 10
    merged = 0
    for template, scene, hand, path, _ in runs:
        again = generate([template], scene, start=hand).path
        np.testing.assert_array_equal(again, path)
        assert np.array_equal(path[0], hand)  # the step begins exactly at the hand
        icps = bind(template, scene, hand)
        src = np.array([template.icps[k] for k in icps])
        raw = imitate(template.path, src, np.array(list(icps.values())), pin={0: hand})
        np.testing.assert_array_equal(raw, path)  # the step is OSILA with the start pinned, nothing after it
        start = template.icps["start"]
        merged += any(np.allclose(template.icps[k], start) and not np.allclose(scene[k], hand)
                      for k in icps if k != "start")
    assert merged >= 4  # the 'back' steps: a scene ICP shares the start's template point, not the hand


def test_hila_imitate_makes_the_interpreters_step(tmp_path):
    template, scene, hand, path, tag = next(r for r in _runs("programs/reach_return.hila") if r[4] == "back")
    task = tmp_path / "task.yaml"
    dump_yaml(task, {"icps": {**{k: np.asarray(v).tolist() for k, v in scene.items()}, "start": hand.tolist()}})
    out = tmp_path / "path.csv"
    assert main(["imitate", "primitives/reach.yaml", "--task", str(task), "--sub", tag, "-o", str(out)]) == 0
    csv, _ = read_demo_csv(out)
    np.testing.assert_allclose(csv, path, rtol=0, atol=1e-12)


def test_bind_names_what_is_wrong():
    t = Template("t", np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), {"a": [0.0, 0.0], "b": [1.0, 1.0]},
                 segments=[Segment("s", 0, 3)])
    sub = t.sub("s")
    with pytest.raises(InputError, match=r"task gives no ICP 'b'"):
        bind(sub, {"a": [0.0, 0.0]})
    with pytest.raises(InputError, match=r"'t.s' is 2-D but ICP 'a' is bound to the 3-D point"):
        bind(sub, {"a": [0.0, 0.0, 0.0], "b": None})
    with pytest.raises(InputError, match=r"no ICP of 't.s' is bound"):
        bind(sub, {"a": None, "b": None})
    assert list(bind(sub, {"a": [0.0, 0.1], "b": None}, hand=[0.5, 0.5])) == ["a", "start"]
    assert list(bind(sub, {"a": [0.0, 0.1], "b": [1, 1], "start": None, "end": [2, 2]}, hand=[0.5, 0.5])) == ["a", "b", "end"]


def test_a_bound_start_is_where_the_step_begins():
    t = Template("t", np.array([[0.0, 0.0], [0.5, 0.2], [1.0, 0.0], [1.0, 1.0]]), {"a": [0.0, 0.0], "b": [1.0, 1.0]},
                 segments=[Segment("s", 0, 4)])
    step = hila_step(t.sub("s"), {"a": [0.0, 0.0], "b": [2.0, 2.0]}, hand=[0.01, -0.02])
    assert step.start_bound and np.array_equal(step.path[0], [0.01, -0.02])
    free = hila_step(t.sub("s"), {"a": [0.0, 0.0], "b": [2.0, 2.0], "start": None}, hand=[0.01, -0.02])
    assert not free.start_bound and not np.array_equal(free.path[0], [0.01, -0.02])
