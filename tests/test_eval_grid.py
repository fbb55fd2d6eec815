"""The evaluation grid: protocols, controls on OSILA's exact constraints, Tables I-III, statistics.

On a small stand-in grid (2 trials per set-up) so it stays fast.
"""

from __future__ import annotations

import io
import re
from dataclasses import replace

import numpy as np
import pytest

from hila_lang.evaluation import controls, paper, stats, tables
from hila_lang.evaluation.dataset import generate
from hila_lang.evaluation.grid import evaluate_row, metric_names, score
from hila_lang.evaluation.protocols import boundaries, constraints, fraction_index, pair_mask, shared_names
from hila_lang.evaluation.run import Progress, run_grid
from hila_lang.metrics import correlation, msd

OPTIONS = {"threshold": 2.0}
ALL = ("osila", "none", "similarity", "tps", "dmp", "dmp-aligned")


@pytest.fixture(scope="module")
def trials():
    return generate(seed=1, trials_per_setup=2)


@pytest.fixture(scope="module")
def paper_result(trials):
    pytest.importorskip("movement_primitives")
    return run_grid(trials, methods=ALL, options=OPTIONS, protocol="paper", progress=False)


# ----------------------------------------------------------------------------- protocols


def test_paper_pairs_add_one_boundary_of_the_task_path_per_inner_cut(trials):
    a, b = trials[0], trials[9]  # exp1 -> exp5: shared names are hand + 4 corners
    assert shared_names(a, b) == ["hand", "object.1", "object.2", "object.3", "object.4"]
    for n in (1, 2, 3, 4):
        c = constraints(a, b, n, "paper")
        assert len(c.src) == 5 + n - 1 and c.n == n
        assert c.at[:5] == (None,) * 5
        if n > 1:
            assert np.array_equal(c.src[5:], a.path[boundaries(len(a.path), n)])
            assert np.array_equal(c.dst[5:], b.path[boundaries(len(b.path), n)])  # the scored path leaks in
            assert list(c.at[5:]) == boundaries(len(a.path), n)
    assert len(constraints(trials[8], trials[9], 1, "paper").src) == 6  # both have a waypoint


def test_held_out_takes_nothing_from_the_scored_path(trials):
    a, b = trials[3], trials[6]
    c = constraints(a, b, 1, "held-out")
    assert c.labels == tuple(shared_names(a, b)) and all(at is None for at in c.at)
    moved = replace(b, path=b.path[::-1] + 50.0)  # a different human path, the same scene
    np.testing.assert_array_equal(constraints(a, moved, 1, "held-out").dst, c.dst)
    with pytest.raises(ValueError, match="held-out protocol has one segment only"):
        constraints(a, b, 2, "held-out")


def test_fractions_are_points_at_k_over_n_of_both_paths(trials):
    a, b = trials[0], trials[1]
    c = constraints(a, b, 4, "fractions")
    assert c.labels == ("t = 0/4", "t = 1/4", "t = 2/4", "t = 3/4", "t = 4/4")
    idx = [fraction_index(len(a.path), k, 4) for k in range(5)]
    assert idx[0] == 0 and idx[-1] == len(a.path) - 1
    np.testing.assert_array_equal(c.src, a.path[idx])
    np.testing.assert_array_equal(c.dst, b.path[[fraction_index(len(b.path), k, 4) for k in range(5)]])


def test_pair_mask(trials):
    every = pair_mask(trials, within_setup_only=False)
    assert every.all()
    within = pair_mask(trials, within_setup_only=True)
    assert within.sum() == 5 * 2 * 1 and not within.diagonal().any()
    assert within[0, 1] and not within[0, 2]


def test_boundaries_are_the_inner_cuts_of_equal_segments():
    assert boundaries(40, 1) == []
    assert boundaries(40, 4) == [10, 20, 30]
    assert boundaries(41, 2) == [20]


# ----------------------------------------------------------------------------- controls


def test_every_method_gets_the_very_constraints_osila_gets(trials, monkeypatch):
    pytest.importorskip("movement_primitives")
    from hila_lang.evaluation import grid

    seen: dict[str, list] = {}
    real = grid.generator

    def spying(method, path, options):
        gen = real(method, path, options)

        def run(c):
            seen.setdefault(method, []).append(c)
            return gen(c)

        return run

    monkeypatch.setattr(grid, "generator", spying)
    evaluate_row(trials, 4, segments=(1, 3), methods=ALL, options=OPTIONS, protocol="paper")
    assert set(seen) == set(ALL)
    for m in ALL:
        assert len(seen[m]) == len(seen["osila"])
        assert all(c is o for c, o in zip(seen[m], seen["osila"]))  # the same object, not a copy


def test_every_control_scores_what_osilas_constraints_give(trials):
    pytest.importorskip("movement_primitives")
    row = evaluate_row(trials, 6, segments=(1, 2), methods=ALL, options=OPTIONS, protocol="paper")
    template = trials[6]
    for m in ALL:
        gen = controls.generator(m, template.path, OPTIONS)
        for s, n in enumerate((1, 2)):
            for j in (0, 3, 9):
                c = constraints(template, trials[j], n, "paper")  # built independently, as for OSILA
                np.testing.assert_allclose(row.scores[m][s, j], score(gen(c), trials[j].path), rtol=1e-12, err_msg=m)


@pytest.mark.parametrize("method", ALL)
def test_no_method_sees_the_task_path_under_held_out(trials, method):
    if method.startswith("dmp"):
        pytest.importorskip("movement_primitives")
    template, task = trials[2], trials[7]
    gen = controls.generator(method, template.path, OPTIONS)
    other = replace(task, path=task.path[::-1] * 1.3)
    np.testing.assert_array_equal(gen(constraints(template, task, 1, "held-out")),
                                  gen(constraints(template, other, 1, "held-out")))


def test_none_passes_through_the_anchors_at_rest(trials):
    template, task = trials[0], trials[5]
    c = constraints(template, task, 3, "paper")
    idx, points = controls.anchors(template.path, c)
    assert idx[0] == 0 and idx[-1] == len(template.path) - 1
    assert list(idx[1:-1]) == boundaries(len(template.path), 3)  # the hand is the start anchor
    np.testing.assert_allclose(points[0], task.icps[task.icp_names.index("hand")])
    path = controls.no_template(template.path, c)
    np.testing.assert_allclose(path[idx], points, atol=1e-9)
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    assert steps[0] < 0.25 * steps.max() and steps[-1] < 0.25 * steps.max()  # starts and ends at rest
    # the cached spline operator is scipy's clamped spline through the anchors
    from scipy.interpolate import CubicSpline

    T = len(template.path)
    direct = CubicSpline(idx / (T - 1), points, axis=0, bc_type="clamped")(np.linspace(0, 1, T))
    np.testing.assert_allclose(path, direct, rtol=1e-12, atol=1e-9)


def test_similarity_control_is_the_least_squares_similarity(trials):
    template, task = trials[1], trials[8]
    c = constraints(template, task, 1, "held-out")
    out = controls.generator("similarity", template.path, {})(c)
    scale, R, shift = controls.similarity(c)
    np.testing.assert_allclose(out, scale * template.path @ R.T + shift)
    # a scene that is an exact similarity of the template's is reproduced exactly
    moved = replace(task, icps=1.5 * template.icps @ np.array([[0, -1], [1, 0]]).T + 7.0,
                    icp_names=template.icp_names)
    c = constraints(template, moved, 1, "held-out")
    np.testing.assert_allclose(controls.generator("similarity", template.path, {})(c),
                               1.5 * template.path @ np.array([[0, -1], [1, 0]]).T + 7.0, atol=1e-9)


def test_dmp_rollouts_by_linearity_equal_direct_rollouts(trials):
    pytest.importorskip("movement_primitives")
    from movement_primitives.dmp import DMP

    template = trials[3]
    ctl = controls.DmpControl(template.path, aligned=False)
    a, b = 0, 20
    start, goal = np.array([10.0, -4.0]), np.array([150.0, 90.0])
    M = np.array([[0.8, -0.6], [0.6, 0.8]]) * 1.3  # scale x rotation, as dmp-aligned uses
    piece = template.path[a : b + 1]
    # the DMP learned from the moved template, rolled out directly by movement_primitives
    moved = piece @ M.T
    dmp = ctl._dmp(2, b - a)
    dmp.imitate(np.arange(len(piece)) * ctl.dt, moved)
    direct = ctl._rollout(dmp, start, goal, len(piece))
    np.testing.assert_allclose(ctl.piece(a, b, start, goal, M), direct, atol=1e-8)
    assert isinstance(dmp, DMP)


def test_dmp_aligned_turns_with_the_scene_and_dmp_does_not(trials):
    pytest.importorskip("movement_primitives")
    template, task = trials[0], trials[1]
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])
    turned = replace(task, icps=task.icps @ rot.T)
    for method, follows in (("dmp-aligned", True), ("dmp", False)):
        gen = controls.generator(method, template.path, {})
        a = gen(constraints(template, task, 1, "held-out"))
        b = gen(constraints(template, turned, 1, "held-out"))
        assert np.allclose(b, a @ rot.T, atol=1e-6) == follows, method


# ----------------------------------------------------------------------------- the grid and the paper's tables


@pytest.mark.slow
def test_table1_self_mapping_reproduces_the_path(paper_result):
    t1 = tables.table1(paper_result)
    assert t1.shape == (4, 5)
    assert (t1 >= 0.999).all(), t1


def test_segmentation_improves_the_cross_mapping(paper_result):
    pairs = stats.distinct_pairs(paper_result)
    mean_msd = [np.nanmean(paper_result.msd["osila"][s][pairs]) for s in range(4)]
    assert mean_msd[3] < 0.5 * mean_msd[0]


def test_osila_is_not_the_bare_warp_in_the_grid(paper_result):
    o, t = paper_result.metric("osila", "msd"), paper_result.metric("tps", "msd")
    assert np.nanmean(np.abs(o - t)) > 1.0  # the route and the map choice change the result


def test_score_resamples_the_shorter_path():
    t = np.linspace(0, 1, 31)
    long = np.column_stack([t, np.sin(3 * t)])
    short = long[::3]  # 11 points spanning the same time
    values = dict(zip(metric_names(2), score(short, long)))
    assert values["r"] > 0.9999 and values["msd"] < 1e-3 and values["frechet"] < 0.05
    assert values["r"] == pytest.approx(correlation(short, long)) and values["msd"] == pytest.approx(msd(short, long))
    assert values["endpoint"] == pytest.approx(0.0)


def test_table2_table3_group_pairs_by_setup(paper_result):
    t2, t3 = tables.table2(paper_result), tables.table3(paper_result)
    assert t2.shape == t3.shape == (4, 5, 5)
    S = paper_result.trial_setup
    r, m = paper_result.r["osila"], paper_result.msd["osila"]
    vals = [r[1, i, j] for i in range(len(S)) for j in range(len(S)) if S[i] == 4 and S[j] == 2]
    assert t2[1, 2, 4] == pytest.approx(np.mean(vals))
    vals = [m[1, i, j] for i in range(len(S)) for j in range(len(S)) if S[i] == 4 and S[j] == 2]
    assert t3[1, 2, 4] == pytest.approx(np.mean(vals))


def test_printed_tables_have_the_papers_layout(paper_result):
    text = tables.render(paper_result)
    for title in ("Methods side by side", "Tests over shapes", "TABLE I:", "TABLE II:", "TABLE III:", "claims"):
        assert title in text
    assert "the paper's protocol on the stand-in" in text
    t1 = tables.format_table1(paper_result).splitlines()
    assert [c.strip() for c in t1[1].split("|")[1:]] == ["exp1", "exp2", "exp3", "exp4", "exp5"]
    assert "(0.991)" in t1[2].split("|")[3]  # the paper's figure beside ours
    t2 = tables.format_table2(paper_result).splitlines()
    rows = [ln for ln in t2 if re.match(r"^(exp\d)?\s*\|\s+\d \|", ln)]
    assert len(rows) == 20
    assert f"{tables.table2(paper_result)[0, 0, 4]:.3f} (0.380)" in rows[0]
    # Table I again with every control, on the same self-mapping pairs
    block = tables.format_table1_methods(paper_result).splitlines()
    assert [ln.split()[0] for ln in block[2:]] == [m for m in paper_result.methods for _ in paper_result.segments]
    tps_n2 = next(ln for ln in block if ln.split()[:2] == ["tps", "2"])
    assert f"{tables.table1(paper_result, 'tps')[1, 0]:.3f}" in tps_n2.split("|")[1]


def test_paper_figures_only_under_the_paper_protocol(trials):
    held = run_grid(trials, methods=("osila",), options=OPTIONS, protocol="held-out", segments=(1,), progress=False)
    text = tables.render(held)
    assert "(0.380)" not in text and "held-out protocol" in text and "claims" not in text


def test_paper_shares_follow_from_its_table():
    assert tables.share(paper.TABLE_II[0], "<", 0.8) == pytest.approx(8 / 25)
    assert tables.share(paper.TABLE_II[1], ">=", 0.8) == pytest.approx(23 / 25)
    assert tables.share(paper.TABLE_II[3], ">", 0.95) == pytest.approx(24 / 25)


def test_summary_rows_are_means_over_pairs_of_different_trials(paper_result):
    rows = {(r["method"], r["n"]): r for r in stats.summary_rows(paper_result)}
    pairs = ~np.eye(10, dtype=bool)
    for m in ALL:
        assert rows[(m, 2)]["pairs"] == 90 and rows[(m, 2)]["failed"] == 0
        assert rows[(m, 2)]["frechet"] == pytest.approx(np.mean(paper_result.metric(m, "frechet")[1][pairs]))
        assert rows[(m, 2)]["ms_per_path"] > 0


def test_tests_take_the_shape_as_the_unit(paper_result):
    from scipy.stats import wilcoxon

    rows = {(r["method"], r["segments"], r["metric"]): r for r in stats.test_rows(paper_result)}
    # MSD is tested only where no timing is given away (paper protocol: N = 1)
    assert {k for k in rows if k[2] == "msd"} == {(m, 1, "msd") for m in ALL[1:]}
    assert {k[:2] for k in rows} == {(m, n) for m in ALL[1:] for n in (1, 2, 3, 4)}
    pairs = ~np.eye(10, dtype=bool)
    setup = paper_result.trial_setup
    per_shape = lambda m: np.array([paper_result.metric(m, "frechet")[1][pairs & (setup == k)[None, :]].mean()  # noqa: E731
                                    for k in range(5)])
    o, c = per_shape("osila"), per_shape("dmp")
    row = rows[("dmp", 2, "frechet")]
    assert row["unit"] == "shape" and row["n"] == 5 and row["pairs"] == 90
    assert row["osila_better_share"] == pytest.approx(np.mean(o < c))
    assert row["p_value"] == pytest.approx(wilcoxon(o, c).pvalue)
    assert row["median_diff"] == pytest.approx(np.median(o - c))
    assert row["ci_low"] <= row["median_diff"] <= row["ci_high"]
    # controls are not in the declared family (OSILA against the baselines): exploratory, no Holm
    assert row["family"] == "exploratory" and np.isnan(row["p_holm"])


def test_joblib_gives_the_local_numbers(trials):
    local = run_grid(trials[:6], methods=("osila", "none"), options=OPTIONS, protocol="paper", progress=False)
    par = run_grid(trials[:6], methods=("osila", "none"), options=OPTIONS, protocol="paper", jobs=2, progress=False)
    assert par.backend == "joblib(2)"
    for m in ("osila", "none"):
        np.testing.assert_array_equal(par.scores[m], local.scores[m])


def test_a_failing_pair_scores_nan_and_is_reported(trials):
    row = evaluate_row(trials, 0, segments=(1, 2), options={"threshold": 2.0, "rounds": 0})
    assert row.scores["osila"].shape == (2, len(trials), len(metric_names(2))) and np.isnan(row.scores["osila"]).all()
    assert len(row.failures["osila"]) == 2 * len(trials)
    assert row.failures["osila"][0].startswith("N=1 exp1/trial01 -> exp1/trial01: expected rounds >= 1")


def test_hila_variant_stitches_one_osila_per_segment(trials):
    from hila_lang.evaluation.grid import _hila_generator

    template, task = trials[2], trials[7]  # exp2 -> exp4
    gen = _hila_generator(template, OPTIONS)
    osila = controls.generator("osila", template.path, OPTIONS)
    c1 = constraints(template, task, 1, "paper")
    np.testing.assert_array_equal(gen(c1), osila(c1))
    for n in (2, 4):
        c = constraints(template, task, n, "paper")
        path = gen(c)
        assert len(template.path) - (n - 1) <= len(path) <= len(template.path) + n  # joints kept once
        assert np.allclose(path[0], task.icps[task.icp_names.index("hand")])
        for d in c.dst[5:]:
            assert np.linalg.norm(path - d, axis=1).min() <= 2.0 + 1e-9
        assert np.linalg.norm(np.diff(path, axis=0), axis=1).min() > 1e-6


def test_progress_bar_reports_every_tenth_when_not_a_terminal():
    buf = io.StringIO()
    bar = Progress(20, stream=buf)
    for _ in range(20):
        bar.update()
    lines = buf.getvalue().splitlines()
    assert 10 <= len(lines) <= 11 and lines[-1].startswith("eval [") and "20/20 rows" in lines[-1]
