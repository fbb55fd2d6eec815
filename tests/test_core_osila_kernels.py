"""The small-K kernels of the warp's first call (osila/tps.py): the merge check, the rank, and
the compiled choice's polar rotations and Gauss-Jordan inverses, against numpy (issue 24)."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.core import jit
from hila_lang.osila import tps


@pytest.fixture(autouse=True)
def _compiled():
    pytest.importorskip("numba")
    if not jit.enabled():
        pytest.skip("HILA_JIT=0")
    tps.forget()
    yield
    tps.forget()


@pytest.mark.parametrize("dim", [2, 3])
def test_merge_with_compiled_distances_merges_what_numpy_merges(dim):
    """merge_pairs with the compiled distances (``fast``) keeps the same pairs as with numpy's,
    also with duplicates and a point at the tolerance along an axis."""
    rng = np.random.default_rng(dim)
    merged = 0
    for trial in range(200):
        K = int(rng.integers(2, 30))
        src = rng.normal(size=(K, dim)) * 10 ** rng.uniform(-3, 3)
        if trial % 3 == 0:  # duplicates, and a point near the tolerance along an axis
            src[rng.integers(K)] = src[0]
            src[-1] = src[1]
            src[-1, 0] += 1e-6 * float(np.ptp(src, axis=0).max())
        dst = rng.normal(size=src.shape)
        slow = tps.merge_pairs(src, dst)
        tps.forget()
        fast = tps.merge_pairs(src, dst, fast=True)
        tps.forget()
        merged += len(slow[0]) < K
        for a, b in zip(slow, fast):
            np.testing.assert_array_equal(a, b)
    assert merged >= 50


def test_rank_kernel_equals_numpy_on_degenerate_sets():
    """3-D ranks by Jacobi rotations equal numpy's eigvalsh ranks: coplanar, collinear, one point
    repeated, thin slabs on both sides of the bound, general sets at any scale."""
    kernel = tps._rank_compiled()
    rng = np.random.default_rng(7)
    seen = set()
    for trial in range(3000):
        K = int(rng.integers(4, 25))
        src = rng.normal(size=(K, 3))
        kind = trial % 6
        if kind == 1:
            src[:, 2] = 0.0  # coplanar
        elif kind == 2:
            src[:, 1:] = 0.0  # collinear
        elif kind == 3:
            src[:] = src[0]  # one point
        elif kind == 4:
            src[:, 2] *= 10 ** rng.uniform(-4.5, -1.5)  # a slab around the 1e-3 bound
        src = src @ np.linalg.qr(rng.normal(size=(3, 3)))[0] * 10 ** rng.uniform(-3, 3) + rng.normal(size=3)
        want = tps._affine_rank(src, tps.DEGENERATE_TOL)
        assert kernel(src, tps.DEGENERATE_TOL) == want
        assert tps.affine_rank(src, fast=True) == want
        seen.add(want)
    assert seen == {0, 1, 2, 3}


def _kernel_choice(src, dst):
    kernel = tps._kernel()
    K, D = src.shape
    card, lin, w, loo = np.empty((K + D + 1, K)), np.empty((D + 1, D)), np.zeros((K, D)), np.empty(K)
    kernel(src, dst, np.zeros(K), card, lin, w, loo)
    return card, lin, w, loo


def test_choice_kernel_polar_rotations_and_inverses_equal_numpy():
    """The compiled choice (Newton's polar rotation for the refits, Gauss-Jordan inverses) equals
    the numpy twin (batched SVD, Cholesky of the projected systems) on rigid, noisy and reflected
    3-D pairs at K = 5..40, and a singular system (two equal template points) is refused."""
    rng = np.random.default_rng(11)
    reflected = 0
    for trial in range(300):
        K = int(rng.integers(5, 41))
        src = rng.normal(size=(K, 3)) * rng.uniform(0.2, 5, 3)
        R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        if trial % 3 == 2:  # a reflection: det covk < 0, the SVD path
            R[:, 0] *= -1 if np.linalg.det(R) > 0 else 1
            reflected += 1
        else:
            R[:, 0] *= -1 if np.linalg.det(R) < 0 else 1
        dst = 1.7 * src @ R.T + rng.normal(0, [0.0, 0.05, 0.5][trial % 3] + 1e-3, src.shape)
        fast = _kernel_choice(src, dst)
        slow = tps._choice_numpy(src, dst, np.zeros(K))
        scale = float(((dst - dst.mean(0)) ** 2).sum(1).max())
        for a, b in zip(fast[:3], slow[:3]):
            np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-9 * np.abs(b).max())
        np.testing.assert_allclose(fast[3], slow[3], rtol=1e-7, atol=1e-12 * scale)
    assert reflected >= 90
    src = rng.normal(size=(6, 3))
    src[3] = src[1]
    with pytest.raises(ZeroDivisionError):
        _kernel_choice(src, src + 1.0)
