"""The warp's systems held as Cholesky factors (osila/saddle.py) give the inverses' diagonals,
products and whole columns of the general inverse, and the same choice (issue 24)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from hila_lang.osila import saddle, tps


def _systems(dim: int, K: int, seed: int):
    rng = np.random.default_rng(seed)
    src = rng.uniform(-1, 1, (K, dim))
    dst = 0.9 * src + 0.1 * np.sin(2 * src[:, ::-1]) + rng.normal(0, 0.01, src.shape)
    mu, sc, A = tps._tps_system(src, np.zeros(K))
    return src, dst, sc, A


def _general_inverse(phi, P):
    K, Q = P.shape
    A = np.zeros((K + Q, K + Q))
    A[:K, :K], A[:K, K:], A[K:, :K] = phi, P, P.T
    return np.linalg.inv(A)[:, :K]


@pytest.mark.parametrize("dim,K", [(2, 7), (2, 230), (3, 8), (3, 230)])
def test_factors_give_the_general_inverse(dim, K):
    """Diagonal, products (with the polynomial rows) and whole columns of both systems' inverses
    equal numpy's general inverse of the bordered matrix; in 3-D from ONE factorisation."""
    src, dst, sc, A = _systems(dim, K, 5 * K + dim)
    sim_phi = tps._dist(src, src) / sc
    before = saddle.FACTORISATIONS[0]
    got = saddle.factored(A[:K, :K], A[:K, K + 1:], sim_phi if dim == 2 else None, 1.0 if dim == 2 else -1.0)
    assert saddle.FACTORISATIONS[0] - before == (2 if dim == 2 else 1)
    refs = (_general_inverse(A[:K, :K], A[:K, K:]), _general_inverse(sim_phi, np.ones((K, 1))))
    for obj, ref in zip(got, refs):
        big = np.abs(ref).max()
        np.testing.assert_allclose(obj.diagonal(), np.diagonal(ref[:K]), rtol=0, atol=1e-9 * big)
        np.testing.assert_allclose(obj.solve(dst), ref @ dst, rtol=0, atol=1e-9 * np.abs(ref @ dst).max())
        np.testing.assert_allclose(obj.gram(dst), ref[:K] @ dst, rtol=0, atol=1e-9 * np.abs(ref @ dst).max())
        np.testing.assert_allclose(obj.full(), ref, rtol=0, atol=1e-9 * big)


def test_a_kernel_matrix_not_definite_gives_none():
    """A 'kernel' matrix that is not conditionally definite: no factor (the caller inverts whole)."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (20, 3))
    phi = rng.normal(size=(20, 20))
    assert saddle.factored(phi + phi.T, x, None, -1.0) is None


@pytest.mark.parametrize("dim", [2, 3])
def test_the_choice_is_the_one_of_the_general_inverses(monkeypatch, dim):
    """fit_warp on the numpy path (K = 150 > KERNEL_MAX_PAIRS) chooses the same map and maps the
    path to rounding whether the choice's inverses come from the factors or whole (the factor
    switched off: the general inverses of :func:`.tps._inverse`), on bench/osila.py's two scenes
    (a rigid placement with noise: the fallback; a smooth bend: the TPS)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
    from osila import scene  # bench/osila.py: the measured scenes

    for kind, chosen in (("fallback", "similarity"), ("tps", "tps")):
        path, src, dst = scene(dim, 400, 150, kind)
        tps.forget()
        fast = tps.fit_warp(src, dst, on=path)
        tps.forget()
        with monkeypatch.context() as m:
            m.setattr(saddle, "factored", lambda *a: None)
            slow = tps.fit_warp(src, dst, on=path)
        tps.forget()
        assert fast.kind == slow.kind == chosen
        assert (fast.amplification is None) == (slow.amplification is None)
        if fast.amplification is not None:
            assert fast.amplification == pytest.approx(slow.amplification, rel=1e-9)
        np.testing.assert_allclose(fast.mapped, slow.mapped, rtol=0, atol=1e-9)
