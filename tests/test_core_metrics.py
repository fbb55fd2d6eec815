"""Metrics: eq. 1 and eq. 2 against hand computations; resampling."""

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.metrics import correlation, frechet, msd, resample


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


# ------------------------------------------------------------------ beyond the paper


@pytest.fixture(params=["kernel", "numpy"])
def metric_backend(request, monkeypatch):
    """Run with the compiled Fréchet/DTW kernels and with the numpy anti-diagonal fallback."""
    from hila_lang.core import jit

    if request.param == "numpy":
        monkeypatch.setattr(jit, "compiled", lambda func, *warm: None)
    return request.param


@pytest.mark.parametrize("n,m", [(40, 40), (23, 61), (1, 7), (9, 1)])
def test_frechet_and_dtw_equal_similaritymeasures(metric_backend, n, m):
    sm = pytest.importorskip("similaritymeasures")
    from hila_lang.metrics import dtw, frechet

    rng = np.random.default_rng(n * 100 + m)
    for dim in (2, 3):
        a = np.cumsum(rng.normal(size=(n, dim)), axis=0)
        b = np.cumsum(rng.normal(size=(m, dim)), axis=0)
        assert frechet(a, b) == pytest.approx(sm.frechet_dist(a, b), rel=1e-12)
        assert dtw(a, b) * max(n, m) == pytest.approx(sm.dtw(a, b)[0], rel=1e-12)


def test_frechet_and_dtw_by_hand():
    from hila_lang.metrics import dtw, frechet

    a = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    b = a + [0.0, 1.0]
    assert frechet(a, b) == pytest.approx(1.0)
    assert dtw(a, b) == pytest.approx(1.0)  # three matched pairs, 1 apart each, / 3
    # a path that waits is the same path to DTW and Fréchet, not to MSD
    slow = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert frechet(a, slow) == 0.0 and dtw(a, slow) == 0.0
    assert frechet(a, a[::-1]) == pytest.approx(2.0)  # direction matters


def test_axis_correlation_and_endpoint_error():
    from hila_lang.metrics import axis_correlation, endpoint_error

    t = np.linspace(0, 1, 50)
    a = np.column_stack([t, np.sin(4 * t)])
    b = np.column_stack([2 * t + 1, -np.sin(4 * t)])
    np.testing.assert_allclose(axis_correlation(a, b), [1.0, -1.0])
    assert correlation(a, b) > -1.0  # pooled R mixes the axes
    flat = np.column_stack([t, np.zeros(50)])
    r = axis_correlation(flat, b)
    assert r[0] == pytest.approx(1.0) and np.isnan(r[1])
    assert endpoint_error(a, b) == pytest.approx(np.linalg.norm(a[-1] - b[-1]))


def test_resampling_through_the_cached_matrix_equals_the_spline():
    from scipy.interpolate import CubicSpline

    from hila_lang.metrics import MATRIX_LIMIT

    rng = np.random.default_rng(11)
    for T, n in ((2, 7), (3, 11), (4, 9), (5, 3), (40, 64), (64, 40), (700, 900), (4, 100_000)):
        path = rng.normal(size=(T, 3)).cumsum(0)
        want = CubicSpline(np.linspace(0, 1, T), path, axis=0)(np.linspace(0, 1, n))
        got = resample(path, n)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(got[[0, -1]], path[[0, -1]])
    assert 700 * 900 > MATRIX_LIMIT  # the last cases took the direct spline


def test_resampling_needs_no_scipy_interpolate():
    """A game scores its marks by resampling; ``scipy.interpolate`` (and the ``scipy.optimize``
    it brings) is not loaded for it."""
    import subprocess
    import sys

    code = ("import sys, numpy as np; from hila_lang.metrics import resample; "
            "resample(np.random.default_rng(0).normal(size=(700, 2)), 200); resample(np.eye(5), 9); "
            "print(sorted(m for m in ('scipy.interpolate', 'scipy.optimize') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_scores_equal_the_single_metrics():
    from hila_lang.metrics import axis_correlation, dtw, endpoint_error, msd, scores

    rng = np.random.default_rng(12)
    a, b = rng.normal(size=(30, 2)).cumsum(0), rng.normal(size=(45, 2)).cumsum(0)
    got = scores(a, b)
    a45 = resample(a, 45)
    want = [correlation(a, b), msd(a, b), frechet(a45, b), dtw(a45, b), endpoint_error(a, b), *axis_correlation(a, b)]
    np.testing.assert_allclose(got, want, rtol=1e-12)
