"""HILA: the paper's A-B-C -> C-B-A-A-C, stitching, start binding, errors."""

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.hierarchy.generate import generate, resolve
from hila_lang.metrics import correlation
from hila_lang.osila.template import Segment, Template


def abc_template():
    t = np.linspace(0, 1, 300)
    path = np.column_stack([3 * t, np.sin(6 * t)])
    icps = {"a": [0.0, 0.0], "b": [3.0, 0.0], "c": [1.5, 1.0], "d": [1.5, -1.0]}
    segs = [Segment("A", 0, 100), Segment("B", 100, 200, True), Segment("C", 200, 300)]
    return Template("demo", path, icps, times=3 * t, segments=segs)


def test_abc_to_cbaac():
    t = abc_template()
    steps = resolve({"demo": t}, ["C", "B", "A", "A", "C"])
    g = generate(steps, t.icps)
    assert g.tags() == ["C", "B", "A", "A", "C"]
    assert [p.contact for p in g.pieces] == [False, True, False, False, False]
    # pieces contiguous and covering; joins shared (first point of each later piece dropped)
    assert g.pieces[0].start == 0 and g.pieces[-1].stop == len(g.path)
    assert all(p.stop == q.start for p, q in zip(g.pieces, g.pieces[1:]))
    assert len(g.path) == 5 * 100 - 4
    # continuity: no jump at a join larger than the template's own largest step (x 3 for warping)
    steps_len = np.linalg.norm(np.diff(g.path, axis=0), axis=1)
    template_step = np.linalg.norm(np.diff(t.path, axis=0), axis=1).max()
    assert steps_len.max() < 3 * template_step
    # each piece after the first starts where the previous one ended, without a jump: the step
    # across the join is about the piece's own next step (the warp stretches a piece smoothly to
    # start at the hand, so both may be a few times the template's step)
    for p, q in zip(g.pieces, g.pieces[1:]):
        joint = g.path[q.start - 1]
        assert np.linalg.norm(g.path[q.start] - joint) <= 1.2 * np.linalg.norm(g.path[q.start + 1] - g.path[q.start])
    # the first step (C, start unbound) reproduces the demonstrated C
    assert correlation(g.path[: g.pieces[0].stop], t.sub("C").path) >= 0.999
    # times continue monotonically
    assert g.times is not None and len(g.times) == len(g.path) and (np.diff(g.times) > 0).all()


def test_start_binds_to_hand_and_is_exact():
    t = abc_template()
    hand = np.array([-0.5, 0.4])
    g = generate([t.sub("A")], t.icps, start=hand)
    np.testing.assert_array_equal(g.path[0], hand)
    # end bound when the task gives it
    g = generate([t.sub("A")], {**t.icps, "end": [1.2, 1.5]}, threshold=0.0)
    np.testing.assert_allclose(g.path[-1], [1.2, 1.5], atol=1e-9)


def test_generate_with_per_step_scenes_and_translation():
    t = abc_template()
    moved = {k: np.asarray(v) + [10.0, 0.0] for k, v in t.icps.items()}
    g = generate(resolve({"demo": t}, ["demo.A", "demo.B"]), [t.icps, moved], threshold=0.0)
    # B in the moved scene, starting where A ended (pinned), otherwise shifted by +10 in x
    b = g.path[g.pieces[1].start :]
    assert b[-1][0] > 9.0


def test_resolve_and_errors():
    t = abc_template()
    assert [s.name for s in resolve({"demo": t}, ["A", "demo.C", "demo"])] == ["demo.A", "demo.C", "demo"]
    with pytest.raises(InputError, match=r"unknown step 'D'; expected one of: demo, demo.A, demo.B, demo.C"):
        resolve({"demo": t}, ["D"])
    with pytest.raises(InputError, match=r"step 'A' is ambiguous: tag of demo, other"):
        resolve({"demo": t, "other": t}, ["A"])
    with pytest.raises(InputError, match=r"step 0 \(demo.A\): task gives no ICP 'c'"):
        generate([t.sub("A")], {"a": [0, 0], "b": [1, 0]})
    with pytest.raises(InputError, match=r"expected at least one step"):
        generate([], t.icps)
    with pytest.raises(InputError, match=r"one task ICP mapping per step \(2\), got 1"):
        generate([t.sub("A"), t.sub("B")], [t.icps])


def test_the_shipped_reach_stays_above_the_paper_from_the_far_side():
    """The reach of ``primitives/circle.yaml`` into cell 9 as the robot saw it in the game of seed
    14 (random opponent): the corners on the paper it saw, the hand lifted beyond the cell's far
    side.  The step's path never goes below the corners' plane (it went 1.1 mm below with the
    similarity fallback; the arm refuses 2 mm below the real paper)."""
    from pathlib import Path

    from hila_lang.hierarchy.step import hila_step
    from hila_lang.osila.template import load_template

    reach = load_template(Path(__file__).resolve().parents[1] / "primitives" / "circle.yaml").sub("reach")
    z = 0.57002
    corners = {"tl": [0.29092, -0.12271, z], "tr": [0.30466, -0.17419, z], "br": [0.25312, -0.18799, z],
               "bl": [0.23937, -0.13651, z]}
    hand = [0.36254, -0.03486, 0.65688]
    step = hila_step(reach, {**corners, "hand": hand, "start": None}, hand)
    assert step.path[:, 2].min() >= z - 1e-6
    assert abs(step.path[-1, 2] - z) < 1e-6  # the pen ends on the paper, where the draw begins
