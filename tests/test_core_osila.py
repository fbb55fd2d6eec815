"""OSILA properties: self-mapping, similarity equivariance, forced waypoints, obstacles, fallbacks."""

import re

import numpy as np
import pytest

from hila_lang.errors import ConstraintError, InputError
from hila_lang.metrics import correlation
from hila_lang.osila import imitate, imitate_detailed
from hila_lang.osila.tps import fit_warp


def wavy_path(T=300, dim=2, seed=0):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, T)
    a, b = rng.uniform(1, 3, 2)
    cols = [t * 2, 0.5 * np.sin(a * np.pi * t)]
    if dim == 3:
        cols.append(0.3 * np.cos(b * np.pi * t))
    return np.column_stack(cols)


def icps_around(path, K, seed):
    rng = np.random.default_rng(seed)
    lo, hi = path.min(0) - 0.2, path.max(0) + 0.2
    return rng.uniform(lo, hi, (K, path.shape[1]))


def rotation(dim, angle, axis=(0.3, -0.5, 0.8)):
    c, s = np.cos(angle), np.sin(angle)
    if dim == 2:
        return np.array([[c, -s], [s, c]])
    k = np.asarray(axis) / np.linalg.norm(axis)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * Kx + (1 - c) * Kx @ Kx


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(4))
def test_self_mapping_reproduces_path(dim, seed):
    path = wavy_path(dim=dim, seed=seed)
    icps = icps_around(path, 6, seed)
    out = imitate(path, icps, icps)
    assert out.shape == path.shape
    assert correlation(out, path) >= 0.999
    thr = 0.01 * np.linalg.norm(np.ptp(path, axis=0))
    assert np.linalg.norm(out - path, axis=1).max() <= thr * (1 + 1e-9)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(4))
def test_similarity_of_icps_moves_path_alike(dim, seed):
    rng = np.random.default_rng(100 + seed)
    path = wavy_path(dim=dim, seed=seed)
    icps = icps_around(path, 7, seed)
    R = rotation(dim, rng.uniform(-np.pi, np.pi))
    scale, shift = rng.uniform(0.5, 2.0), rng.normal(0, 1, dim)
    move = lambda p: scale * p @ R.T + shift  # noqa: E731
    res = imitate_detailed(path, icps, move(icps))
    assert res.warp.kind == "tps"
    err = np.linalg.norm(res.path - move(path), axis=1)
    assert err.max() <= res.threshold * (1 + 1e-6)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(3))
def test_forced_waypoints_are_passed(dim, seed):
    rng = np.random.default_rng(200 + seed)
    path = wavy_path(dim=dim, seed=seed)
    icps = icps_around(path, 6, seed)
    task = icps + rng.normal(0, 0.05, icps.shape)
    # forced points near, but off, the plain imitation
    plain = imitate(path, icps, task)
    forced = plain[[60, 150, 240]] + rng.normal(0, 0.08, (3, dim))
    res = imitate_detailed(path, icps, task, forced=forced)
    d = np.linalg.norm(res.path[:, None, :] - forced[None], axis=2).min(0)
    assert (d <= res.threshold * (1 + 1e-9)).all(), d
    assert res.rounds >= 2 and len(res.added) >= 1


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("seed", range(3))
def test_no_waypoint_inside_obstacles(dim, seed):
    rng = np.random.default_rng(300 + seed)
    path = wavy_path(dim=dim, seed=seed)
    icps = icps_around(path, 6, seed)
    plain = imitate(path, icps, icps)
    obstacles = []
    for t in (80, 200):
        centre = plain[t] + rng.normal(0, 0.02, dim)
        obstacles.append(np.append(centre, 0.08))
    obstacles = np.array(obstacles)
    res = imitate_detailed(path, icps, icps, obstacles=obstacles, margin=0.01)
    for ob in obstacles:
        assert (np.linalg.norm(res.path - ob[:-1], axis=1) >= ob[-1] + 0.01 - 1e-12).all()
    # and the route still follows the template elsewhere
    assert correlation(res.path, path) > 0.95


def test_obstacles_as_dicts_equal_rows():
    path = wavy_path()
    icps = icps_around(path, 5, 1)
    c = path[150]
    a = imitate(path, icps, icps, obstacles=[[c[0], c[1], 0.05]])
    b = imitate(path, icps, icps, obstacles=[{"centre": list(c), "radius": 0.05}])
    np.testing.assert_array_equal(a, b)


def test_contradiction_is_named():
    path = wavy_path()
    icps = icps_around(path, 5, 2)
    with pytest.raises(ConstraintError, match=r"forced waypoint 0 at \(1, 0\) lies inside obstacle 0"):
        imitate(path, icps, icps, forced=[[1.0, 0.0]], obstacles=[[1.0, 0.0, 0.2]])


def test_unreachable_within_rounds_names_pairs():
    path = wavy_path()
    icps = icps_around(path, 5, 3)
    forced = [[5.0, 5.0], [-5.0, -5.0], [5.0, -5.0]]
    with pytest.raises(ConstraintError, match=r"could not conform after 1 round\(s\): forced waypoint 0 at \(5, 5\) missed"):
        imitate(path, icps, icps, forced=forced, rounds=1)


def test_unreachable_names_only_the_first_pairs():
    # an obstacle covering the whole scene: a repair pair per round that cannot help
    path = wavy_path()
    icps = icps_around(path, 5, 4)
    with pytest.raises(ConstraintError) as info:
        imitate(path, icps, icps, obstacles=[[0.0, 0.0, 50.0]], rounds=8)
    tried = str(info.value).split("Constraint pairs tried: ")[1]
    assert tried.count("template[") == 5 and re.search(r"; and \d+ more", tried)


@pytest.mark.parametrize(
    "K,dim,kind",
    [(1, 2, "translation"), (2, 2, "similarity"), (1, 3, "translation"), (2, 3, "similarity"), (3, 3, "similarity")],
)
def test_too_few_icps_fall_back(K, dim, kind):
    path = wavy_path(dim=dim)
    rng = np.random.default_rng(K)
    icps = rng.normal(0, 1, (K, dim))
    R = rotation(dim, 0.7)
    moved = 1.5 * icps @ R.T + 0.3
    res = imitate_detailed(path, icps, moved)
    assert res.warp.kind == kind
    if kind == "similarity" and K >= dim:  # rotation fully determined
        np.testing.assert_allclose(res.warp(path), 1.5 * path @ R.T + 0.3, atol=1e-9)
    else:  # maps the ICPs themselves exactly
        np.testing.assert_allclose(res.warp(icps), moved, atol=1e-9)


def test_coplanar_icps_in_3d_use_similarity_and_five_points_use_tps():
    corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    R = rotation(3, 0.4)
    moved = 0.8 * corners @ R.T + [0.1, 0.2, 0.3]
    assert fit_warp(corners, moved).kind == "similarity"
    np.testing.assert_allclose(fit_warp(corners, moved)([[0.5, 0.5, 0.7]]), 0.8 * np.array([[0.5, 0.5, 0.7]]) @ R.T + [0.1, 0.2, 0.3], atol=1e-9)
    hand = np.array([[0.2, 0.3, 0.5]])
    both = np.vstack([corners, hand])
    assert fit_warp(both, 0.8 * both @ R.T).kind == "tps"


def test_coinciding_template_icps_last_pair_wins():
    src = np.array([[0, 0], [1, 0], [0, 1], [1, 1], [0, 0]], float)
    dst = src.copy()
    dst[-1] = [0.3, -0.2]
    warp = fit_warp(src, dst)
    np.testing.assert_allclose(warp([[0.0, 0.0]]), [[0.3, -0.2]], atol=1e-9)
    np.testing.assert_allclose(warp(src[1:4]), dst[1:4], atol=1e-9)


def test_tps_interpolates_exactly_and_smoothing_approximates():
    rng = np.random.default_rng(5)
    for dim in (2, 3):
        src = rng.normal(0, 1, (9, dim))
        dst = src + rng.normal(0, 0.2, src.shape)
        np.testing.assert_allclose(fit_warp(src, dst)(src), dst, atol=1e-9)
        smooth = fit_warp(src, dst, smoothing=1.0)
        assert np.abs(smooth(src) - dst).max() > 1e-4


def test_pin_keeps_mapped_point():
    path = wavy_path()
    icps = icps_around(path, 5, 4)
    res = imitate_detailed(path, icps, icps + 0.1, pin=(0, -1))
    np.testing.assert_array_equal(res.path[[0, -1]], res.mapped[[0, -1]])


@pytest.mark.parametrize(
    "args,kwargs,message",
    [
        ((np.zeros(5), np.zeros((3, 2)), np.zeros((3, 2))), {}, r"expected path of shape \(T, D\) with D in \{2, 3\}, got \(5,\)"),
        ((np.zeros((0, 2)), np.zeros((3, 2)), np.zeros((3, 2))), {}, r"at least 1 point\(s\), got an empty path"),
        ((np.zeros((5, 4)), np.zeros((3, 4)), np.zeros((3, 4))), {}, r"D in \{2, 3\}, got \(5, 4\)"),
        ((np.array([[0, 0], [np.nan, 1]]), np.zeros((3, 2)), np.zeros((3, 2))), {}, r"expected finite path, got nan at index \(1, 0\)"),
        ((np.zeros((5, 2)), np.zeros((0, 2)), np.zeros((0, 2))), {}, r"at least one point in template_icps \(K >= 1\), got K = 0"),
        ((np.zeros((5, 2)), np.zeros((3, 2)), np.zeros((4, 2))), {}, r"paired by row, got K = 3 and K = 4"),
        ((np.zeros((5, 2)), np.zeros((3, 3)), np.zeros((3, 3))), {}, r"template_icps of shape \(K, 2\) to match the path's D = 2, got \(3, 3\)"),
        ((np.zeros((5, 2)), np.zeros((3, 2)), np.full((3, 2), np.inf)), {}, r"expected finite task_icps"),
        ((np.zeros((5, 2)), np.zeros((3, 2)), np.zeros((3, 2))), {"treshold": 1}, r"unknown option 'treshold'"),
        ((np.zeros((5, 2)), np.zeros((3, 2)), np.zeros((3, 2))), {"rounds": 0}, r"expected rounds >= 1, got 0"),
        ((np.zeros((5, 2)), np.zeros((3, 2)), np.zeros((3, 2))), {"obstacles": [[0, 0, -1]]}, r"obstacle radii > 0, got -1.0 in row 0"),
    ],
)
def test_bad_input_says_what_came(args, kwargs, message):
    with pytest.raises(InputError, match=message):
        imitate(*args, **kwargs)
    with pytest.raises(ValueError):  # the contract: a ValueError
        imitate(*args, **kwargs)


def test_single_point_path_and_zero_threshold():
    out = imitate([[1.0, 2.0]], [[0.0, 0.0]], [[1.0, 1.0]])
    np.testing.assert_allclose(out, [[2.0, 3.0]])
    path = wavy_path()
    icps = icps_around(path, 5, 6)
    res = imitate_detailed(path, icps, icps * 1.1, threshold=0)
    np.testing.assert_array_equal(res.path, res.mapped)
