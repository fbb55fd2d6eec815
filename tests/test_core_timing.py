"""OSILA's defaults that come from the data: the ball from the template's noise, re-timing of on-path ICPs."""

import numpy as np
import pytest

from hila_lang.core.errors import InputError
from hila_lang.metrics import frechet, msd
from hila_lang.osila import imitate, imitate_detailed
from hila_lang.osila.fallback import fit_similarity
from hila_lang.osila.noise import NOISE_MULTIPLE, position_noise
from hila_lang.osila.timing import WINDOW, _bending, _similarity_ss, retime, timed_stamps
from hila_lang.osila.tps import affine_rank, fit_warp, kernel
from hila_lang.osila.motion import minimum_jerk


def stroke(T, skew=1.0, dim=2):
    """A curved stroke drawn with a minimum-jerk speed profile, its speed peak moved by ``skew``."""
    s = minimum_jerk(np.linspace(0.0, 1.0, T) ** skew)
    cols = [2.0 * s, 0.6 * np.sin(2.5 * np.pi * s)]
    if dim == 3:
        cols.append(0.3 * np.cos(1.5 * np.pi * s))
    return np.column_stack(cols)


def fractions(template, task, n):
    a = [round(k * (len(template) - 1) / n) for k in range(n + 1)]
    b = [round(k * (len(task) - 1) / n) for k in range(n + 1)]
    return a, template[a], task[b]


def task_times(task, n):
    """When the task passes its points at time fractions k/N: the pairs' task times."""
    return [round(k * (len(task) - 1) / n) / (len(task) - 1) for k in range(n + 1)]


# ------------------------------------------------------------------ the ball: the template's noise


@pytest.mark.parametrize("sigma", [0.3, 0.8])
def test_position_noise_recovers_white_noise_on_a_smooth_movement(sigma):
    rng = np.random.default_rng(1)
    clean = 100.0 * stroke(80)  # pixels: a 200 px reach sampled at 80 points
    est = [position_noise(clean + rng.normal(0, sigma, clean.shape)) for _ in range(20)]
    assert np.mean(est) == pytest.approx(sigma, rel=0.1)
    assert position_noise(clean) < 0.02 * sigma  # the movement itself is not noise


def test_the_default_ball_is_twice_the_mapped_paths_noise():
    rng = np.random.default_rng(2)
    path = stroke(150) + rng.normal(0, 0.004, (150, 2))
    icps = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 0.8], [1.0, -0.8], [0.3, 0.5]])
    res = imitate_detailed(path, icps, 1.3 * icps + 0.2)
    assert res.threshold == pytest.approx(NOISE_MULTIPLE * position_noise(res.mapped))
    assert res.threshold == pytest.approx(2 * 1.3 * 0.004, rel=0.2)


def test_a_clean_template_keeps_its_shape_where_a_fixed_ball_cuts_corners():
    path = stroke(120)
    icps = np.array([[0.0, 0.0], [2.0, 0.0], [1.0, 0.8], [1.0, -0.8], [0.3, 0.5]])
    task = 1.2 * icps + 0.1
    res = imitate_detailed(path, icps, task)
    exact = fit_warp(icps, task)(path)
    assert res.threshold < 1e-3 * np.linalg.norm(np.ptp(exact, axis=0))
    cut = imitate(path, icps, task, threshold=0.01 * np.linalg.norm(np.ptp(exact, axis=0)))
    assert frechet(res.path, exact) < 0.2 * frechet(cut, exact)


# ------------------------------------------------------------------ re-timing on-path ICPs


def test_similarity_residual_and_bending_energy_equal_direct_fits():
    rng = np.random.default_rng(3)
    for dim in (2, 3):
        Y = rng.normal(size=(6, dim))
        S = rng.normal(size=(4, 6, dim))
        ss = _similarity_ss(S, Y)
        for b in range(4):
            scale, R, shift = fit_similarity(S[b], Y, affine_rank(S[b]))
            assert ss[b] == pytest.approx(float(((S[b] @ (scale * R).T + shift - Y) ** 2).sum()), rel=1e-9)
        mu, sc = S[0].mean(0), float(np.abs(S[0] - S[0].mean(0)).max())
        E = _bending(S, Y, mu, sc)
        for b in range(4):  # the TPS through the pairs, by its textbook system; energy Σ_ij w_i·w_j U(r_ij)
            x = (S[b] - mu) / sc
            U = np.array([[kernel(np.array(np.linalg.norm(p - q)), dim) for q in x] for p in x], dtype=float)
            P = np.hstack([np.ones((6, 1)), x])
            A = np.block([[U, P], [P.T, np.zeros((dim + 1, dim + 1))]])
            w = np.linalg.solve(A, np.vstack([Y, np.zeros((dim + 1, dim))]))[:6]
            assert E[b] == pytest.approx(float(np.trace(w.T @ U @ w)), rel=1e-8)


@pytest.mark.parametrize("n", [2, 3, 4])
def test_a_later_speed_peak_is_recovered_and_every_pair_met_at_its_own_stamp(n):
    template, task_shape = stroke(100, skew=1.0), stroke(90, skew=1.1)
    R = np.array([[np.cos(0.4), -np.sin(0.4)], [np.sin(0.4), np.cos(0.4)]])
    task = 1.3 * task_shape @ R.T + [5.0, -2.0]  # the same stroke, moved, drawn with its speed peak later
    stamps, src, dst = fractions(template, task, n)
    res = imitate_detailed(template, src, dst, task_times=task_times(task, n))
    assert res.retimed, "the pairs disagree in timing: some must move"
    # the task reaches each point later in the stroke than the template does at the same time
    assert all(s < t for t, s in res.retimed.items())
    np.testing.assert_array_equal(res.path[stamps], dst)  # still met exactly, at the pair's own stamp
    kept = imitate_detailed(template, src, dst, timing=0, task_times=task_times(task, n))
    assert kept.retimed == {}
    for metric in (msd, frechet):
        assert metric(res.path, task) < 0.75 * metric(kept.path, task)
    # the same points without their times are positions: nothing to re-time
    positions = imitate_detailed(template, src, dst)
    assert positions.retimed == {}
    np.testing.assert_array_equal(positions.path, kept.path)


def test_the_same_timing_moves_nothing():
    template = stroke(100)
    task = 0.8 * template + [1.0, 2.0]
    stamps, src, dst = fractions(template, task, 4)
    res = imitate_detailed(template, src, dst, task_times=task_times(task, 4))
    assert res.retimed == {}
    np.testing.assert_allclose(res.path, task, atol=res.threshold * (1 + 1e-9))


def test_ends_pins_and_scene_icps_never_move():
    template, task = stroke(100), 1.1 * stroke(100, skew=1.3)
    stamps, src, dst = fractions(template, task, 4)
    scene = np.array([[1.0, 1.5], [1.0, -1.5]])
    src2, dst2 = np.vstack([scene, src]), np.vstack([1.1 * scene, dst])
    out = retime(template, src2, dst2, 0.03, fixed=(stamps[2],), times=[None, None, *task_times(task, 4)])
    assert out.stamps and stamps[2] not in out.stamps and 0 not in out.stamps and 99 not in out.stamps
    np.testing.assert_array_equal(out.src[:2], scene)  # off the path: nothing to re-time
    for t, s in out.stamps.items():
        assert abs(s - t) <= 4 * 0.03 * 99 + 1
        np.testing.assert_array_equal(out.path[t], template[s])
    # the re-timed template is the same shape, in order
    assert np.all(np.diff(np.interp(np.arange(100), sorted(out.stamps), [out.stamps[t] for t in sorted(out.stamps)])) >= 0)
    for k, t in enumerate(stamps):  # each moved pair's template point is the template's point it now has
        np.testing.assert_array_equal(out.src[k + 2], template[out.stamps.get(t, t)])


def test_only_pairs_whose_timing_agrees_are_re_timed():
    template = stroke(101)
    stamps = [0, 25, 50, 75, 100]
    src = template[stamps]
    assert timed_stamps(template, src, None, 0.03) == set()  # positions: no pair carries a time
    assert timed_stamps(template, src, [0.0, 0.25, 0.5, 0.75, 1.0], 0.03) == set(stamps)
    assert timed_stamps(template, src, [0.0, 0.25, 0.5, 0.75, 1.0], 0.0) == set()  # timing = 0: none
    # a pair whose task time is outside the window of its template point's own time is a position
    off = 0.5 + 1.01 * WINDOW * 0.03
    assert timed_stamps(template, src, [0.0, 0.25, off, 0.75, 1.0], 0.03) == {0, 25, 75, 100}
    assert timed_stamps(template, src, [0.0, 0.25, 0.5 + 0.99 * WINDOW * 0.03, 0.75, 1.0], 0.03) == set(stamps)
    # task times against the path's order: the timing contradicts the template, no pair is re-timed
    assert timed_stamps(template, src, [0.0, 0.3, 0.27, 0.75, 1.0], 0.03) == set()
    # unknown times (None / NaN) leave those pairs as positions; a scene point off the path carries nothing
    assert timed_stamps(template, src, [None, 0.25, float("nan"), 0.75, None], 0.03) == {25, 75}
    scene = np.vstack([src, [[1.0, 2.0]]])
    assert timed_stamps(template, scene, [0.0, 0.25, 0.5, 0.75, 1.0, 0.6], 0.03) == set(stamps)


def test_task_times_option_is_checked():
    with pytest.raises(InputError, match="one entry per ICP pair"):
        imitate(stroke(20), [[0, 0], [2, 0]], [[0, 0], [2, 0]], task_times=[0.0])
    with pytest.raises(InputError, match=r"\[0, 1\] or None, got 1.5 for pair 1"):
        imitate(stroke(20), [[0, 0], [2, 0]], [[0, 0], [2, 0]], task_times=[0.0, 1.5])


def test_timing_option_is_checked():
    with pytest.raises(InputError, match="timing"):
        imitate(stroke(20), [[0, 0], [2, 0]], [[0, 0], [2, 0]], timing=-0.1)


def test_the_noise_estimate_s_median_is_numpy_s_bit_for_bit():
    """position_noise's one-partition median (a default imitate pays two) against np.median on
    seeded arrays of odd and even sizes, scaled from tiny to large."""
    import numpy as np

    from hila_lang.osila.noise import _median

    rng = np.random.default_rng(38)
    for n in (1, 2, 3, 4, 7, 100, 101, 1999, 2000):
        for _ in range(20):
            x = rng.normal(size=n) * 10.0 ** rng.uniform(-6, 6) + rng.uniform(-5, 5)
            assert _median(x) == float(np.median(x))
