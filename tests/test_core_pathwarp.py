"""The path warp (hila_lang.osila.pathwarp): Laplacian coordinates of the path kept, pairs met."""

from __future__ import annotations

import numpy as np
import pytest

from hila_lang.osila import imitate, imitate_detailed
from hila_lang.osila.fallback import fit_similarity
from hila_lang.osila.pathwarp import LENGTH_GRID, NOISE_GRID, anchored, choose_warp, length_scale, offsets_matrix
from hila_lang.osila.tps import fit_warp


def hairpin(T=200):
    """Out and back: two strokes 4 % of the extent apart; the task bulges the return stroke only."""
    t = np.linspace(0, 1, T)
    path = np.column_stack([np.sin(np.pi * t), 0.08 * t])
    bump = np.where(t > 0.5, np.sin(np.pi * (t - 0.5) / 0.5) ** 2, 0.0)
    return path, path + np.column_stack([np.zeros(T), 0.3 * bump])


def laplacian(T):
    """The path graph's Laplacian, densely: row t is e_t minus the mean of its neighbours."""
    L = np.eye(T)
    for t in range(T):
        nb = [u for u in (t - 1, t + 1) if 0 <= u < T]
        L[t, nb] -= 1.0 / len(nb)
    return L


@pytest.mark.parametrize("seed", range(6))
def test_offsets_equal_the_dense_least_squares_reference(seed):
    rng = np.random.default_rng(seed)
    T = int(rng.integers(5, 120))
    stamps = tuple(sorted(rng.choice(T, int(rng.integers(1, min(T, 8) + 1)), replace=False).tolist()))
    mu = float(rng.choice([0.0, 10.0 ** rng.uniform(-9, -1)]))
    r = rng.normal(size=(len(stamps), 2))
    # slow and obvious: min |L e|² + mu |e|² over the free stamps, e fixed at the stamps, by lstsq
    A = np.vstack([laplacian(T), np.sqrt(mu) * np.eye(T)])
    free = np.setdiff1d(np.arange(T), stamps)
    want = np.zeros((T, 2))
    want[list(stamps)] = r
    if free.size:
        want[free] = np.linalg.lstsq(A[:, free], -A[:, list(stamps)] @ r, rcond=None)[0]
    got = offsets_matrix(T, stamps, mu) @ r
    np.testing.assert_allclose(got, want, atol=1e-9 * max(1.0, np.abs(want).max()))
    np.testing.assert_array_equal(offsets_matrix(T, stamps, mu)[list(stamps)], np.eye(len(stamps)))


def _log_likelihood(u, y, ell, noise):
    """The GP's log marginal likelihood (up to a constant), by a Cholesky factor: the textbook way."""
    K = np.exp(-0.5 * (u[:, None] - u[None, :]) ** 2 / ell**2) + noise * np.eye(len(u))
    c = np.linalg.cholesky(K)
    a = np.linalg.solve(c, y)
    return float(-0.5 * (a * a).sum() - y.shape[1] * np.log(np.diag(c)).sum())


@pytest.mark.parametrize("seed", range(3))
def test_the_length_scale_maximises_the_marginal_likelihood(seed):
    rng = np.random.default_rng(seed)
    T = 80
    t = np.linspace(0, 1, T)
    path = np.column_stack([np.cos(rng.uniform(1, 6) * t), np.sin(rng.uniform(1, 6) * t)])
    path += rng.normal(0, 1e-3, path.shape)
    ell = length_scale(path)
    u = t[np.unique(np.round(np.linspace(0, T - 1, 50)).astype(int))]
    y = path[np.round(u * (T - 1)).astype(int)]
    y = (y - y.mean(0)) / np.abs(y - y.mean(0)).max()
    fine = np.exp(np.linspace(np.log(LENGTH_GRID[0]), np.log(LENGTH_GRID[-1]), 400))
    best = max((_log_likelihood(u, y, e, n), e) for e in fine for n in NOISE_GRID[::4])
    # the search finds the same optimum as a 400-point grid, within a grid step of its own
    assert abs(np.log(ell / best[1])) <= np.log(LENGTH_GRID[1] / LENGTH_GRID[0])


def test_a_faster_movement_has_a_shorter_length_scale():
    t = np.linspace(0, 1, 120)
    slow = np.column_stack([t, np.sin(2 * np.pi * t)])
    fast = np.column_stack([t, np.sin(8 * np.pi * t)])
    assert length_scale(fast) < 0.5 * length_scale(slow)


def test_a_bend_of_one_stroke_stays_in_that_stroke():
    """Where two strokes pass close in space, a spatial warp carries one's correction onto the
    other; the path warp spreads it along the path only.  Fails if the warp is the similarity or
    the bare TPS."""
    path, task = hairpin()
    idx = [0, 50, 100, 150, 199]
    res = imitate_detailed(path, path[idx], task[idx])
    assert res.warp.kind == "path"
    err = lambda m: float(np.linalg.norm(m - task, axis=1).max())  # noqa: E731
    scale, R, shift = fit_similarity(path[idx], task[idx], 2)
    similarity, tps = scale * path @ R.T + shift, fit_warp(path[idx], task[idx])(path)
    assert err(res.path) < 0.06
    assert err(similarity) > 3 * err(res.path) and err(tps) > 2.5 * err(res.path)
    np.testing.assert_array_equal(res.path[idx], task[idx])  # every on-path pair met exactly
    # the outgoing stroke keeps its shape: its Laplacian coordinates barely change
    L = laplacian(len(path))
    assert np.abs((L @ (res.path - path))[1:90]).max() < 0.1 * np.abs((L @ (tps - path))[1:90]).max() + 1e-4


def test_the_path_keeps_the_templates_laplacian_coordinates_best():
    """Without a route, the path warp is the damped Laplacian edit of the similarity-placed template:
    moving any free waypoint raises |L(m - b)|² + mu |m - b|²."""
    from hila_lang.osila.pathwarp import damping

    path, task = hairpin(120)
    idx = [0, 40, 80, 119]
    warp = choose_warp(path[idx], task[idx], on=path)
    assert warp.kind == "path"
    b = warp.base(path)
    mu = damping(path)
    L = laplacian(len(path))

    def energy(m):
        e = m - b
        return float((L @ e).ravel() @ (L @ e).ravel() + mu * (e * e).sum())

    E = energy(warp.mapped)
    rng = np.random.default_rng(0)
    for t in rng.choice(np.setdiff1d(np.arange(len(path)), idx), 10, replace=False):
        for d in np.eye(2):
            moved = warp.mapped.copy()
            moved[t] += 1e-4 * d
            assert energy(moved) > E


def test_off_path_pairs_bend_space_and_on_path_pairs_the_path():
    path, task = hairpin()
    on_idx = [0, 100, 199]
    scene = np.array([[0.5, 0.5], [0.2, -0.4], [0.9, -0.3]])  # scene points the path does not pass
    moved_scene = 1.1 * scene + [0.05, 0.02]
    src = np.vstack([scene, path[on_idx]])
    dst = np.vstack([moved_scene, task[on_idx]])
    warp = choose_warp(src, dst, on=path)
    assert warp.kind == "path" and sorted(warp.at) == on_idx
    np.testing.assert_allclose(warp(scene), moved_scene, atol=1e-9)  # the spatial map meets the scene exactly
    np.testing.assert_array_equal(warp.mapped[on_idx], task[on_idx])


def test_the_path_warp_needs_both_ends_of_the_path():
    path, task = hairpin()
    assert anchored(path, path[[0, 100, 199]]) and not anchored(path, path[[0, 100]])
    assert not anchored(path, path[[5, 100, 199]])
    warp = choose_warp(path[[10, 100, 190]], task[[10, 100, 190]], on=path)  # the ends free: spatial
    assert warp.kind != "path"
    assert choose_warp(path[[0, 100, 199]], task[[0, 100, 199]], on=path).kind == "path"
    assert choose_warp(path[[0, 100, 199]], task[[0, 100, 199]], on=path, along=False).kind != "path"
    assert fit_warp(path[[0, 100, 199]], task[[0, 100, 199]], on=path).kind != "path"  # the spatial choice


def test_a_via_bends_the_path_warp_and_keeps_both_ends():
    path, task = hairpin()
    hand, goal = task[0] + [0.02, -0.03], task[-1]
    plain = imitate(path, path[[0, 199]], task[[0, 199]], pin={0: hand, -1: goal})
    via = plain[60] + [0.0, 0.15]
    res = imitate_detailed(path, path[[0, 199]], task[[0, 199]], pin={0: hand, -1: goal}, forced=[via])
    assert res.warp.kind == "path" and res.rounds >= 2
    np.testing.assert_array_equal(res.path[0], hand)
    np.testing.assert_array_equal(res.path[-1], goal)
    assert np.linalg.norm(res.path - via, axis=1).min() <= res.threshold * (1 + 1e-9) + 1e-12


def test_explain_says_the_path_was_bent():
    from hila_lang.hierarchy.explain import warp_reason

    path, task = hairpin()
    warp = choose_warp(path[[0, 100, 199]], task[[0, 100, 199]], on=path)
    assert warp_reason(warp, 2).startswith("the path bent along itself: all 3 pairs lie on the template's path")


def test_a_short_paths_warp_does_not_start_the_compiled_kernels(monkeypatch):
    """The path warp's merge of its few pairs uses the compiled distances only for a path of at
    least ``MIN_STAMPS`` stamps (as :func:`fit_warp` does): a game's short strokes never pay
    numba's start-up (0.45 s of CPU), and the warp is the same as with the kernel asked for."""
    from hila_lang.core import jit
    from hila_lang.osila import tps

    t = np.linspace(0.0, 1.0, 60)
    on = np.column_stack([t, np.sin(3 * t)])
    src = on[[0, 20, 40, 59]]
    dst = 1.1 * src + np.array([0.2, -0.1]) + np.random.default_rng(0).normal(0, 0.01, src.shape)
    kernel = tps._dist_compiled()
    asked = []
    monkeypatch.setattr(tps, "_dist_compiled", lambda: asked.append(1) or kernel)
    warp = choose_warp(src, dst, on=on)
    assert len(on) < jit.MIN_STAMPS and asked == []
    with jit.batch():  # every path on the kernels: the same warp, bit for bit
        kernel_warp = choose_warp(src, dst, on=on)
    assert asked and warp.kind == kernel_warp.kind == "path"
    np.testing.assert_array_equal(warp.mapped, kernel_warp.mapped)
