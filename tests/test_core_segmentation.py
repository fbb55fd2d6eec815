"""Segmentation: contiguous, covering, deterministic; tags and contact flags."""

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.osila.segmentation import (
    DEFAULT_METHOD,
    changepoint_cuts,
    changepoint_segments,
    equal_segments,
    kmeans_segments,
    segment_template,
    segments,
    speed_segments,
)
from hila_lang.osila.template import Template


def three_phase(T_each=(40, 120, 40), seed=0):
    """Reach (a line), a circle, retract (a line): the tic-tac-toe demonstration's shape, 2-D."""
    rng = np.random.default_rng(seed)
    a = np.linspace([0, 0], [1, 1], T_each[0], endpoint=False)
    ang = np.linspace(0, 2 * np.pi, T_each[1], endpoint=False)
    b = np.column_stack([1 + 0.15 * np.cos(ang) - 0.15, 1 + 0.15 * np.sin(ang)])
    c = np.linspace([1, 1], [2, 0.3], T_each[2])
    return np.vstack([a, b, c]) + rng.normal(0, 0.002, (sum(T_each), 2))


def assert_contiguous_cover(ranges, T):
    assert ranges[0][0] == 0 and ranges[-1][1] == T
    for (a, b), (c, d) in zip(ranges, ranges[1:]):
        assert b == c
    assert all(b > a for a, b in ranges)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("k", [1, 2, 3, 5, 8])
def test_kmeans_segments_contiguous_and_covering(seed, k):
    rng = np.random.default_rng(seed)
    path = np.cumsum(rng.normal(0, 1, (int(rng.integers(30, 200)), 2 + seed % 2)), axis=0)
    ranges = kmeans_segments(path, k, seed=seed)
    assert len(ranges) == k
    assert_contiguous_cover(ranges, len(path))


def test_kmeans_is_deterministic_and_finds_phases():
    path = three_phase()
    a = kmeans_segments(path, 3, seed=0)
    assert a == kmeans_segments(path, 3, seed=0)
    # boundaries near the true ones (40, 160): within 15 % of the path
    assert abs(a[0][1] - 40) <= 30 and abs(a[1][1] - 160) <= 30, a


@pytest.mark.parametrize("seed", range(3))
def test_kmeans_finds_unequal_phases_where_an_equal_split_does_not(seed):
    """The paper's option must be k-means, not an equal split in disguise: phases of 30, 100 and
    70 samples (true cuts 30 and 130), where equal thirds cut at 67 and 133."""
    path = three_phase((30, 100, 70), seed)
    truth = np.array([30, 130])
    cuts = np.array([a for a, _ in kmeans_segments(path, 3, seed=0)[1:]])
    equal = np.array([a for a, _ in equal_segments(len(path), 3)[1:]])
    assert np.abs(equal - truth).max() > 30  # the case tells the two apart
    assert np.abs(cuts - truth).max() <= 12, cuts


def test_equal_segments():
    assert equal_segments(10, 3) == [(0, 3), (3, 7), (7, 10)]
    for T in (5, 17, 100):
        for n in range(1, 6):
            assert_contiguous_cover(equal_segments(T, n), T)
    with pytest.raises(InputError, match=r"cannot split 3 points into 4 non-empty segments"):
        equal_segments(3, 4)


def test_segment_template_tags_contact_and_errors():
    path = three_phase()
    t = Template("demo", path, {"a": [0.0, 0.0]}, times=np.arange(len(path)) * 0.05)
    s = segment_template(t, 3, ["reach", "draw", "retract"], contact=["draw"])
    assert s.tags() == ["reach", "draw", "retract"]
    assert [g.contact for g in s.segments] == [False, True, False]
    assert t.segments == []  # the input is not modified
    e = segment_template(t, 4, list("abcd"), method="equal")
    assert [(g.start, g.stop) for g in e.segments] == equal_segments(len(path), 4)
    with pytest.raises(InputError, match=r"expected 3 tags for k = 3 segments, got 2: a, b"):
        segment_template(t, 3, ["a", "b"])
    with pytest.raises(InputError, match=r"contact tag 'drw' is not one of the tags a, b"):
        segment_template(t, 2, ["a", "b"], contact=["drw"])
    with pytest.raises(InputError, match=r"unknown segmentation method 'spectral'"):
        segment_template(t, 2, ["a", "b"], method="spectral")
    assert segment_template(t, 2, ["a", "b"]).segments == segment_template(t, 2, ["a", "b"], method=DEFAULT_METHOD).segments
    with pytest.raises(InputError, match=r"cannot split 200 points into k = 500 segments"):
        kmeans_segments(path, 500)


def _demonstrate():
    """The tic-tac-toe demonstration model."""
    from hila_lang.worlds.tictactoe.demonstration import demonstrate

    return demonstrate


def legs(durations, seed=0, tremor=0.0003, rate=20.0):
    """Minimum-jerk legs through random via points; returns (path, times, true cuts)."""
    from hila_lang.worlds.scripted.demos import movement

    rng = np.random.default_rng(seed)
    points = rng.uniform([0.15, -0.3, 0.6], [0.4, 0.1, 0.75], (len(durations) + 1, 3))
    path, marks = movement(points, durations, [0.03] * len(durations), rng)
    return path, np.arange(len(path)) / rate, marks[1:-1]


@pytest.mark.parametrize("seed", range(6))
def test_default_segmenter_cuts_where_the_hand_stops_not_at_equal_lengths(seed):
    rng = np.random.default_rng(seed)
    durations = list(rng.uniform(0.6, 2.6, 3))
    path, times, truth = legs(durations, seed)
    cuts = [a for a, _ in segments(path, 3, times=times)[1:]]
    assert np.abs(np.array(cuts) - truth).max() <= 2, (cuts, truth)
    equal = [a for a, _ in equal_segments(len(path), 3)[1:]]
    if np.abs(np.array(equal) - truth).max() > 4:  # where an equal split is wrong, so are we not
        assert cuts != equal


def test_speed_segments_pick_the_deepest_dips_not_tremor():
    # a slow start with tremor flickers must not win over the stop between two strokes
    path, times, truth = legs([1.2, 2.0], seed=3, tremor=0.001)
    assert [a for a, _ in speed_segments(path, 2, times=times)[1:]] == pytest.approx(truth, abs=1)
    # every segment keeps at least two points; too many segments is an error
    short = path[:9]
    ranges = speed_segments(short, 4, times=times[:9])
    assert all(b - a >= 2 for a, b in ranges) and ranges[-1][1] == 9
    with pytest.raises(InputError, match=r"cannot split 9 points into k = 5 segments of at least 2 points"):
        speed_segments(short, 5)
    with pytest.raises(InputError, match=r"strictly increasing times"):
        speed_segments(path, 2, times=np.zeros(len(path)))


def test_circle_learned_through_the_eyes_is_cut_at_pen_contact():
    from pathlib import Path

    demonstrate = _demonstrate()
    from hila_lang.osila.template import load_template

    seen = load_template(Path(__file__).resolve().parents[1] / "primitives" / "circle.yaml")
    demo = demonstrate(0)  # the movement the eyes saw, with the true pen contact
    cuts = [a for a, _ in segments(seen.path, 3, times=seen.times)[1:]]
    contact = np.flatnonzero(demo.contact)
    assert abs(cuts[0] - contact[0]) <= 1 and abs(cuts[1] - (contact[-1] + 1)) <= 1
    v = np.linalg.norm(np.gradient(seen.path, seen.times, axis=0), axis=1)
    assert v[cuts].max() < 0.1 * v.max()  # cut where the hand is slow, not near peak speed
    kmeans = [a for a, _ in kmeans_segments(seen.path, 3, times=seen.times)[1:]]
    assert v[kmeans].min() > 0.5 * v.max()  # the paper's k-means cuts mid-stroke (issue 11)


def test_circle_model_in_five_strokes_is_cut_at_its_four_stops():
    demonstrate = _demonstrate()

    demo = demonstrate(1)
    on, off = np.flatnonzero(demo.contact)[[0, -1]] + [0, 1]
    cuts = [a for a, _ in segments(demo.path, 5, times=demo.times)[1:]]
    assert abs(cuts[1] - on) <= 1 and abs(cuts[2] - off) <= 1
    xy = demo.path[:, :2]
    assert np.allclose(xy[cuts[0]], xy[on], atol=1e-9)  # the descent starts above the first ink
    assert np.allclose(xy[cuts[3] - 1], xy[off - 1], atol=1e-9)  # the lift ends above the last ink


def test_changepoint_segments():
    path, times, truth = legs([1.0, 1.8, 1.2], seed=2)
    ranges = changepoint_segments(path, 3, times=times)
    assert len(ranges) == 3 and ranges[0][0] == 0 and ranges[-1][1] == len(path)
    assert all(b - a >= 2 for a, b in ranges)


def _l2_cost(x, cuts):
    bounds = [0, *cuts, len(x)]
    return sum(((x[a:b] - x[a:b].mean(0)) ** 2).sum() for a, b in zip(bounds[:-1], bounds[1:]))


def test_changepoint_cuts_reach_the_exhaustive_optimum():
    """The fast cuts (binary segmentation + refinement, O(k T)) against every admissible cut set."""
    import itertools

    rng = np.random.default_rng(7)
    for _ in range(25):
        T, k = int(rng.integers(12, 40)), int(rng.integers(2, 4))
        x = rng.normal(size=(T, 2))
        for part in np.array_split(np.arange(T), k + int(rng.integers(0, 3))):
            x[part] += rng.normal(scale=2.0, size=2)
        best = min(_l2_cost(x, c) for c in itertools.combinations(range(2, T - 1), k - 1)
                   if all(b - a >= 2 for a, b in zip((0, *c), (*c, T))))
        assert _l2_cost(x, changepoint_cuts(x, k)) == pytest.approx(best, rel=1e-12)


def test_changepoint_cuts_beat_equal_and_find_clear_steps():
    """A plain equal split is not a change-point detector: clear steps are found to the sample."""
    rng = np.random.default_rng(3)
    x = np.concatenate([np.full((37, 3), 0.0), np.full((81, 3), 4.0), np.full((23, 3), -2.0)])
    x += rng.normal(scale=0.1, size=x.shape)
    assert changepoint_cuts(x, 3) == [37, 118]


def test_changepoint_is_linear_in_length():
    """5000 samples (a 250 s demonstration at 20 Hz) is cheap and bounded in memory: O(k T)."""
    import tracemalloc

    x = np.random.default_rng(0).normal(size=(5000, 3))
    tracemalloc.start()
    changepoint_cuts(x, 4)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20 * 5000 * 3 * 8  # a few copies of the signal, never T x T (200 MB)


