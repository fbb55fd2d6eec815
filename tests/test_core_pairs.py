"""One binding shape: a template's ICPs become :class:`hila_lang.osila.Pairs` once, in
:func:`hila_lang.hierarchy.step.bind`, and OSILA gets those very arrays."""

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.hierarchy import step as step_module
from hila_lang.hierarchy import step as step_module
from hila_lang.hierarchy.step import bind, hila_step
from hila_lang.osila import Pairs
from hila_lang.osila.template import Segment, Template


def _sub():
    t = Template("t", np.array([[0.0, 0.0], [0.5, 0.2], [1.0, 0.0], [1.0, 1.0]]),
                 {"a": [0.0, 0.0], "b": [1.0, 1.0]}, segments=[Segment("s", 0, 4)])
    return t.sub("s")


def test_bind_pairs_template_and_task_points_by_name_in_the_templates_order():
    sub = _sub()
    pairs = bind(sub, {"b": [2.0, 2.0], "a": [0.0, 0.1], "end": [3.0, 3.0]}, hand=[0.5, 0.5])
    assert isinstance(pairs, Pairs)
    assert pairs.names == tuple(n for n in sub.icps if n in ("a", "b", "start", "end"))
    assert np.array_equal(pairs.src, np.array([sub.icps[n] for n in pairs.names]))
    assert np.array_equal(pairs["start"], [0.5, 0.5]) and np.array_equal(pairs["b"], [2.0, 2.0])
    assert dict(pairs.items()).keys() == set(pairs.names)  # a mapping name -> task point
    pins = pairs.pins()
    assert sorted(pins) == [-1, 0] and np.array_equal(pins[0], [0.5, 0.5]) and np.array_equal(pins[-1], [3, 3])
    with pytest.raises(KeyError):
        pairs["nothere"]


def test_the_step_gives_osila_the_pairs_arrays_unchanged(monkeypatch):
    import hila_lang.osila as osila

    seen = {}
    real = osila.imitate_detailed

    def spy(path, src, dst, **options):
        seen.update(src=src, dst=dst, pin=options.get("pin"))
        return real(path, src, dst, **options)

    monkeypatch.setattr(step_module, "imitate_detailed", spy)  # where the step reads it
    step = hila_step(_sub(), {"a": [0.0, 0.0], "b": [2.0, 2.0]}, hand=[0.01, -0.02])
    assert seen["src"] is step.icps.src and seen["dst"] is step.icps.dst  # one shape, not rebuilt
    assert np.array_equal(seen["pin"][0], [0.01, -0.02])


def test_pairs_know_osilas_tolerances():
    p = Pairs(("start", "a", "b"), np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 1.0]]),
              np.array([[0.5, 0.5], [0.0, 0.0], [2.0, 2.0]]))
    path = np.array([[0.0, 0.0], [0.5, 0.5], [1.0, 1.0]])
    assert p.groups() == [["start", "a"]]
    assert [(a, b) for a, b, _ in p.coincident(path)] == [("start", "a")]
    assert p.coincident(path, threshold=1.0) == []  # closer than the threshold: one point anyway
    assert p.through(path) == {"start", "a", "b"}
    assert p.without("a").names == ("start", "b") and len(p.without("a").src) == 2
    assert p.renamed("ICP 2 lies inside obstacle 0; ICP 7") == "ICP 'b' lies inside obstacle 0; ICP 7"
    lifted = p.mapped(lambda q: np.append(q, 0.57))
    assert lifted.dst.shape == (3, 3) and lifted.src.shape == (3, 2) and lifted["b"][2] == 0.57
    with pytest.raises(ValueError, match="one row per name"):
        Pairs(("a",), np.zeros((2, 2)), np.zeros((2, 2)))


def test_a_hand_start_over_a_bound_icp_wins_with_a_note_and_two_bound_ones_are_an_error():
    sub = _sub()  # its start is where 'a' is in the demonstration
    step = hila_step(sub, {"a": [0.3, 0.3], "b": [2.0, 2.0]}, hand=[0.0, 0.0])
    assert "a" not in step.icps and step.notes and "'a' is where 't.s' starts" in step.notes[0]
    with pytest.raises(InputError, match="ICPs 'a' and 'start'|ICPs 'start' and 'a'"):
        hila_step(sub, {"a": [0.3, 0.3], "b": [2.0, 2.0], "start": [0.0, 0.0]})
