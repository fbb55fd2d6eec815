"""Segmentation: contiguous, covering, deterministic; tags and contact flags."""

import numpy as np
import pytest

from hila_lang.errors import InputError
from hila_lang.segmentation import equal_segments, kmeans_segments, segment_template
from hila_lang.template import Template


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
    with pytest.raises(InputError, match=r"cannot split 200 points into k = 500 segments"):
        kmeans_segments(path, 500)
