"""The vectorised Viterbi equals the slow reference; candidate sets stay in the ball."""

import numpy as np
import pytest

from hila_lang.osila.candidates import ball_offsets
from hila_lang.osila.route import min_energy_route, min_energy_route_reference, route_energy


@pytest.mark.parametrize("seed", range(12))
def test_vectorised_dp_equals_reference(seed):
    rng = np.random.default_rng(seed)
    dim = 2 + seed % 2
    T = int(rng.integers(2, 25))
    centres = np.cumsum(rng.normal(0, 1, (T, dim)), axis=0)
    offsets = rng.normal(0, 0.5, (int(rng.integers(1, 9)), dim))  # random (not lattice): no ties
    distortion = float(rng.choice([0.0, 0.5, 3.0]))
    blocked = rng.random((T, len(offsets))) < 0.3 if seed % 3 == 0 else None
    fast, e_fast = min_energy_route(centres, offsets, distortion, blocked)
    slow, e_slow = min_energy_route_reference(centres, offsets, distortion, blocked)
    assert e_fast == pytest.approx(e_slow, rel=1e-9, abs=1e-9)
    np.testing.assert_array_equal(fast, slow)
    assert e_fast == pytest.approx(route_energy(centres + offsets[fast], centres, distortion), rel=1e-9)
    if blocked is not None:
        free = ~blocked
        ok = ~free.any(1) | free[np.arange(T), fast]
        assert ok.all()


def test_dp_beats_every_random_route():
    rng = np.random.default_rng(42)
    centres = np.cumsum(rng.normal(0, 1, (15, 2)), axis=0)
    offsets = ball_offsets(2, 0.3)
    choice, energy = min_energy_route(centres, offsets)
    for _ in range(200):
        other = rng.integers(0, len(offsets), 15)
        assert route_energy(centres + offsets[other], centres) >= energy - 1e-9


@pytest.mark.parametrize("dim,M", [(2, 17), (3, 29)])
def test_ball_offsets_fill_the_ball(dim, M):
    off = ball_offsets(dim, 0.5)
    assert off.shape == (M, dim)
    np.testing.assert_array_equal(off[0], np.zeros(dim))
    r = np.linalg.norm(off, axis=1)
    assert r.max() == pytest.approx(0.5) and (r <= 0.5 + 1e-12).all()
    assert len(np.unique(np.round(off, 12), axis=0)) == M  # no duplicates
    np.testing.assert_allclose(off.mean(0), 0, atol=1e-12)  # symmetric: no drift bias
    assert ball_offsets(dim, 0.0).shape == (1, dim)


@pytest.fixture(params=["kernel", "numpy"])
def backend(request, monkeypatch):
    """Run a test with the compiled route kernel and with the numpy fallback."""
    from hila_lang.osila import route

    if request.param == "numpy":
        monkeypatch.setattr(route, "_compiled_route", lambda: None)
    elif route._compiled_route() is None:
        pytest.skip("numba is not available")
    else:
        monkeypatch.setattr(route, "min_stamps", lambda: 0)  # the kernel for every length, short ones included
    return request.param


@pytest.mark.parametrize("seed", range(6))
def test_both_backends_equal_reference(backend, seed):
    rng = np.random.default_rng(50 + seed)
    dim = 2 + seed % 2
    T = int(rng.integers(1, 30))
    centres = np.cumsum(rng.normal(0, 1, (T, dim)), axis=0)
    offsets = rng.normal(0, 0.5, (int(rng.integers(1, 9)), dim))
    blocked = rng.random((T, len(offsets))) < 0.3 if seed % 2 else None
    pinned = sorted({0, T - 1, int(rng.integers(0, T))}) if seed % 3 else []
    fast, e_fast = min_energy_route(centres, offsets, 0.5 * seed, blocked, pinned=pinned)
    ref_blocked = np.zeros((T, len(offsets)), bool) if blocked is None else blocked.copy()
    for t in pinned:
        ref_blocked[t] = True
        ref_blocked[t, 0] = False
    slow, e_slow = min_energy_route_reference(centres, offsets, 0.5 * seed, ref_blocked)
    np.testing.assert_array_equal(fast, slow)
    assert (fast[pinned] == 0).all()
    assert e_fast == pytest.approx(e_slow, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_and_numpy_break_ties_alike(monkeypatch, dim):
    # lattice offsets and a straight, evenly sampled path: many exact ties
    from hila_lang.osila import route

    if route._compiled_route() is None:
        pytest.skip("numba is not available")
    centres = np.zeros((200, dim))
    centres[:, 0] = np.linspace(0, 1, 200)
    centres[80:120, 1] = 0.01  # a step: the route must choose among equal-cost detours
    offsets = ball_offsets(dim, 0.01)
    compiled = min_energy_route(centres, offsets)
    monkeypatch.setattr(route, "_compiled_route", lambda: None)
    np.testing.assert_array_equal(compiled[0], min_energy_route(centres, offsets)[0])
    assert compiled[1] == min_energy_route(centres, offsets)[1]


def test_jit_switched_off_or_failing_falls_back_to_numpy(monkeypatch):
    from hila_lang.core import jit
    from hila_lang.osila import route

    centres = np.cumsum(np.random.default_rng(1).normal(0, 1, (40, 2)), axis=0)
    offsets = ball_offsets(2, 0.3)
    expected = min_energy_route_reference(centres, offsets)[0]
    monkeypatch.setenv("HILA_JIT", "0")
    jit.reset()
    assert route._compiled_route() is None
    np.testing.assert_array_equal(min_energy_route(centres, offsets)[0], expected)
    # numba present but compiling (with or without its on-disk cache) fails: numpy, no error
    monkeypatch.setenv("HILA_JIT", "1")
    jit.reset()
    calls = []

    def broken(func, warm, cache):
        calls.append(cache)
        raise RuntimeError("cannot cache function: no locator available")

    monkeypatch.setattr(jit, "_compile", broken)
    pytest.importorskip("numba")
    assert route._compiled_route() is None and calls == [True, False]
    np.testing.assert_array_equal(min_energy_route(centres, offsets)[0], expected)
    jit.reset()


@pytest.mark.slow
def test_jit_without_a_usable_cache_compiles_uncached(monkeypatch):
    from hila_lang.core import jit

    pytest.importorskip("numba")
    monkeypatch.setenv("HILA_JIT", "1")
    real = jit._compile
    tried = []

    def no_cache(func, warm, cache):
        tried.append(cache)
        if cache:
            raise OSError("read-only file system")
        return real(func, warm, cache)

    jit.reset()
    monkeypatch.setattr(jit, "_compile", no_cache)
    from hila_lang.osila import route

    kernel = route._compiled_route()
    assert kernel is not None and tried == [True, False]
    jit.reset()


def test_short_paths_never_start_numba(monkeypatch):
    from hila_lang.osila import route

    calls = []
    monkeypatch.setattr(route, "_compiled_route", lambda: calls.append(1))
    from hila_lang.core import jit

    centres = np.cumsum(np.random.default_rng(2).normal(0, 1, (jit.MIN_STAMPS - 1, 2)), axis=0)
    min_energy_route(centres, ball_offsets(2, 0.3))
    assert calls == []
    with jit.batch():  # batch work: every length
        min_energy_route(centres, ball_offsets(2, 0.3))
    assert calls == [1] and jit.min_stamps() == jit.MIN_STAMPS


@pytest.mark.parametrize("dim,T,seed", [(2, 300, 0), (3, 300, 1), (3, 2000, 2), (2, 2000, 3)])
def test_pruned_kernel_equals_full_scan(monkeypatch, dim, T, seed):
    # the kernel's minimum skips candidates that cannot win (route.py); on smooth paths of coarse
    # and fine steps, with blocked candidates and pins, it returns the numpy scan's route and
    # energy bit for bit (the scan visits every candidate)
    from hila_lang.osila import route

    if route._compiled_route() is None:
        pytest.skip("numba is not available")
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, T)
    centres = np.column_stack([np.cos(t) * (1 + 0.3 * np.sin(3 * t)), np.sin(t), 0.2 * np.sin(2 * t)][:dim])
    centres += rng.normal(0, 0.002, centres.shape)  # a noisy recording: the route irons it out
    offsets = ball_offsets(dim, 0.03)
    blocked = rng.random((T, len(offsets))) < 0.05
    pinned = [0, T // 3, T - 1]
    compiled = min_energy_route(centres, offsets, 0.0, blocked, pinned=pinned)
    assert len(np.unique(compiled[0])) > 3  # the route does use the ball
    monkeypatch.setattr(route, "_compiled_route", lambda: None)
    scan = min_energy_route(centres, offsets, 0.0, blocked, pinned=pinned)
    np.testing.assert_array_equal(compiled[0], scan[0])
    assert compiled[1] == scan[1]


@pytest.mark.parametrize("seed", range(4))
def test_pruned_kernel_breaks_exact_ties_as_the_scan(monkeypatch, seed):
    # integer offsets and centres: every cost is an exact integer, so equal costs abound; the
    # pruned kernel returns the scan's first minimum at every stamp
    from hila_lang.osila import route

    if route._compiled_route() is None:
        pytest.skip("numba is not available")
    rng = np.random.default_rng(seed)
    dim = 2 + seed % 2
    offsets = np.vstack([np.zeros(dim), rng.integers(-2, 3, (12, dim))]).astype(float)
    offsets = np.unique(offsets, axis=0)
    centres = np.cumsum(rng.integers(-1, 2, (60, dim)), axis=0).astype(float)
    blocked = rng.random((60, len(offsets))) < 0.2
    distortion = float(seed % 2)
    monkeypatch.setattr(route, "min_stamps", lambda: 0)  # the kernel for this short path too
    compiled = min_energy_route(centres, offsets, distortion, blocked, pinned=[0])
    monkeypatch.setattr(route, "_compiled_route", lambda: None)
    scan = min_energy_route(centres, offsets, distortion, blocked, pinned=[0])
    np.testing.assert_array_equal(compiled[0], scan[0])
    assert compiled[1] == scan[1]


@pytest.mark.parametrize("dim,scale,seed", [(2, 1e-7, 0), (3, 1e-7, 1), (2, 1e-4, 2), (3, 3e-3, 3), (2, 0.05, 4)])
def test_kernel_equals_full_scan_for_narrow_and_wide_balls(monkeypatch, dim, scale, seed):
    # OSILA's default ball on a clean path is tiny (2 σ of its noise): every candidate's G is far
    # below the differences of the costs, the case where the kernel takes the cheapest previous
    # candidate's way without a scan (route.py); across ball sizes from that to a wide one, and
    # with pins and blocked candidates, the route and energy are the numpy scan's bit for bit
    from hila_lang.osila import route

    if route._compiled_route() is None:
        pytest.skip("numba is not available")
    rng = np.random.default_rng(seed)
    T = 1000
    t = np.linspace(0, 2 * np.pi, T)
    centres = np.column_stack([np.cos(t) * (1 + 0.3 * np.sin(3 * t)), np.sin(t), 0.2 * np.sin(2 * t)][:dim])
    centres += rng.normal(0, scale / 10, centres.shape)
    offsets = ball_offsets(dim, scale)
    blocked = rng.random((T, len(offsets))) < 0.05 if seed % 2 else None
    pinned = [0, T // 2, T - 1]
    compiled = min_energy_route(centres, offsets, float(seed % 2), blocked, pinned=pinned)
    assert len(np.unique(compiled[0])) > 3  # the route does use the ball
    monkeypatch.setattr(route, "_compiled_route", lambda: None)
    scan = min_energy_route(centres, offsets, float(seed % 2), blocked, pinned=pinned)
    np.testing.assert_array_equal(compiled[0], scan[0])
    assert compiled[1] == scan[1]
