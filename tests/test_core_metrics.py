"""Metrics: eq. 1 and eq. 2 against hand computations; resampling."""

import numpy as np
import pytest

from hila_lang.errors import InputError
from hila_lang.metrics import correlation, msd, resample


def test_correlation_matches_eq1_by_hand():
    rng = np.random.default_rng(0)
    a, b = rng.normal(0, 1, (50, 3)), rng.normal(0, 1, (50, 3))
    num = sum(np.dot(a[i] - a.mean(0), b[i] - b.mean(0)) for i in range(50))
    den = np.sqrt(sum(np.dot(x - a.mean(0), x - a.mean(0)) for x in a) * sum(np.dot(y - b.mean(0), y - b.mean(0)) for y in b))
    assert correlation(a, b) == pytest.approx(num / den, rel=1e-12)
    assert correlation(a, a) == pytest.approx(1.0)
    assert correlation(a, -a) == pytest.approx(-1.0)
    assert correlation(a, 3 * a + 7) == pytest.approx(1.0)


def test_msd_matches_eq2():
    a = np.array([[0.0, 0.0], [1.0, 1.0]])
    b = np.array([[1.0, 0.0], [1.0, 3.0]])
    assert msd(a, b) == pytest.approx((1 + 4) / 2)
    assert msd(a, a) == 0.0


def test_resample_is_cubic_and_keeps_ends():
    u = np.linspace(0, 1, 7)
    path = np.column_stack([u, u**3 - u])
    out = resample(path, 31)
    v = np.linspace(0, 1, 31)
    np.testing.assert_allclose(out, np.column_stack([v, v**3 - v]), atol=1e-12)  # cubic: exact
    np.testing.assert_array_equal(out[[0, -1]], path[[0, -1]])
    assert resample([[1.0, 2.0]], 4).shape == (4, 2)
    assert resample(np.arange(5.0), 9).shape == (9, 1)


def test_different_lengths_are_resampled_to_the_longer():
    u = np.linspace(0, 1, 40)
    long = np.column_stack([u, np.sin(3 * u)])
    short = long[::3]
    assert correlation(long, short) > 0.9999
    assert msd(long, short) == pytest.approx(msd(long, resample(short, 40)))


def test_metric_errors():
    with pytest.raises(InputError, match=r"path a has no spread \(all 3 points equal\)"):
        correlation(np.ones((3, 2)), np.random.default_rng(0).normal(size=(3, 2)))
    with pytest.raises(InputError, match=r"same dimension, got D = 2 and D = 3"):
        msd(np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(InputError, match=r"expected finite b"):
        msd(np.zeros((3, 2)), np.full((3, 2), np.nan))
    with pytest.raises(InputError, match=r"expected n >= 1, got 0"):
        resample(np.zeros((3, 2)), 0)
