"""Plan adjustment's refits border the last round's inverses while the pairs only grow (issue 24)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from hila_lang.osila import bordered, imitate_detailed
from hila_lang.osila.tps import KERNEL_MAX_PAIRS, fit_warp

adjust_module = importlib.import_module("hila_lang.osila.adjust")
tps_module = importlib.import_module("hila_lang.osila.tps")


def pairs(seed: int, dim: int, K: int, bend: float):
    rng = np.random.default_rng(seed)
    src = rng.uniform(-1, 1, (K, dim))
    dst = 1.1 * src + bend * np.sin(2 * src[:, ::-1]) + rng.normal(0, 0.01 if bend == 0 else 1e-4, (K, dim))
    t = np.linspace(0, 2 * np.pi, 400)
    path = 0.8 * np.column_stack([np.cos(t), np.sin(t), 0.3 * np.sin(2 * t)][:dim])
    return src, dst, path


@pytest.mark.parametrize("seed,dim,bend", [(0, 2, 0.15), (1, 3, 0.15), (2, 2, 0.0), (3, 3, 0.0), (4, 2, 0.05)])
def test_grown_inverses_give_the_fresh_fit(seed, dim, bend):
    """Pairs that grow (new ones appended, and some placed before the last rows as adjustment's
    repair pairs go before the pins): the bordered fit equals a fresh one to rounding — the same
    map chosen, the same leave-one-out error, the same mapped path (rtol 1e-9) — and only the
    first fit factorised."""
    K = KERNEL_MAX_PAIRS + 40
    src, dst, path = pairs(seed, dim, K + 9, bend)
    refits = bordered.Refits(reuse=True)
    first = fit_warp(src[:K], dst[:K], on=path, refits=refits)
    for new in (4, 9):  # two rounds: 4 pairs, then 5 more, placed before the last 5 (pins go last)
        rows = np.concatenate([np.arange(K - 5), np.arange(K, K + new), np.arange(K - 5, K)])
        grown = fit_warp(src[rows], dst[rows], on=path, refits=refits)
        fresh = fit_warp(src[rows], dst[rows], on=path)
        assert grown.kind == fresh.kind
        np.testing.assert_allclose(grown.mapped, fresh.mapped, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(grown(path[::7] + 0.01), fresh(path[::7] + 0.01), rtol=1e-9, atol=1e-9)
        if fresh.loo is not None:
            assert grown.loo == pytest.approx(fresh.loo, rel=1e-9)
    assert (refits.fresh, refits.bordered) == (1, 2)
    assert first.kind in ("tps", "similarity")


def test_a_dropped_or_moved_pair_or_smoothing_factorises_afresh():
    src, dst, path = pairs(7, 2, KERNEL_MAX_PAIRS + 30, 0.1)
    refits = bordered.Refits(reuse=True)
    fit_warp(src[:-3], dst[:-3], on=path, refits=refits)
    fit_warp(src[1:], dst[1:], on=path, refits=refits)  # pair 0 dropped: not a growth
    assert (refits.fresh, refits.bordered) == (2, 0)
    moved = src.copy()
    moved[5] += 0.01
    fit_warp(moved, dst, on=path, refits=refits)  # a pair's template point moved (re-timing)
    assert (refits.fresh, refits.bordered) == (3, 0)
    fit_warp(np.vstack([moved, [[0.05, 0.07]]]), np.vstack([dst, [[0.1, 0.1]]]), on=path, refits=refits)
    assert (refits.fresh, refits.bordered) == (3, 1)
    # smoothed: a ridge is not invariant under the kept normalisation, so no refit goes through it
    fit_warp(src, dst, 0.1, exact=np.zeros(len(src), bool), on=path, refits=refits)
    assert (refits.fresh, refits.bordered) == (3, 1)


def scene_with_obstacles(dim: int, K: int):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "bench"))
    from osila import adjustment_scene  # bench/osila.py: the measured scene

    return adjustment_scene(dim, 1000, K)


@pytest.mark.parametrize("dim", [2, 3])
def test_adjustment_factorises_once(monkeypatch, dim):
    """A run of several rounds: with the bordered update the two systems are factorised once (the
    first round: the outlier screen's factors, which the warp reuses), without it once per
    round; the routes agree to rounding.  A factorisation per system in 2-D, one for both in 3-D
    (the same kernel matrix: :mod:`hila_lang.osila.saddle`); no general inverse taken."""
    from hila_lang.osila import saddle

    path, src, dst, threshold, obstacles = scene_with_obstacles(dim, 120)
    calls = []
    real = tps_module._inverse

    def counted(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(tps_module, "_inverse", counted)
    runs = {}
    for reuse in (True, False):
        monkeypatch.setattr(bordered, "REUSE", reuse)
        tps_module._LAST[0] = None  # no choice remembered from the other run
        calls.clear()
        before = saddle.FACTORISATIONS[0]
        runs[reuse] = imitate_detailed(path, src, dst, threshold=threshold, obstacles=obstacles, rounds=20)
        runs[reuse, "calls"] = saddle.FACTORISATIONS[0] - before
        assert not calls  # every inverse from the factors
    rounds = runs[True].rounds
    per_round = 2 if dim == 2 else 1
    assert rounds >= 3 and runs[False].rounds == rounds
    assert runs[True, "calls"] == per_round  # the first round only
    assert runs[False, "calls"] == per_round * rounds
    np.testing.assert_allclose(runs[True].path, runs[False].path, rtol=1e-9, atol=1e-9)
    assert runs[True].warp.kind == runs[False].warp.kind
