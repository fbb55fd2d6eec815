"""The cross-mapping grid, Tables I-III and the peers, on a small stand-in grid (2 trials per set-up)."""

from __future__ import annotations

import io
import re

import numpy as np
import pytest

from hila_lang.evaluation import paper, tables
from hila_lang.evaluation.dataset import generate
from hila_lang.evaluation.grid import boundaries, constraint_pairs, evaluate_row, score, shared_icps
from hila_lang.evaluation.run import Progress, run_grid
from hila_lang.metrics import correlation, msd

OPTIONS = {"threshold": 2.0}


@pytest.fixture(scope="module")
def trials():
    return generate(seed=1, trials_per_setup=2)


@pytest.fixture(scope="module")
def result(trials):
    return run_grid(trials, methods=("osila", "tps", "dmp"), options=OPTIONS, progress=False)


def test_table1_self_mapping_reproduces_the_path(result):
    t1 = tables.table1(result)
    assert t1.shape == (4, 5)
    assert (t1 >= 0.999).all(), t1
    diag = np.diagonal(result.r["osila"], axis1=1, axis2=2)
    assert (diag >= 0.999).all()


def test_segmentation_improves_the_cross_mapping(result):
    mean_r = np.nanmean(result.r["osila"], axis=(1, 2))
    mean_msd = np.nanmean(result.msd["osila"], axis=(1, 2))
    assert mean_r[3] > mean_r[0] + 0.02
    assert mean_msd[3] < 0.5 * mean_msd[0]


def test_constraint_pairs_add_one_pair_per_inner_boundary(trials):
    a, b = trials[0], trials[9]  # exp1 -> exp5: shared names are hand + 4 corners
    src, dst = shared_icps(a, b)
    assert len(src) == 5
    for n in (1, 2, 3, 4):
        s, d = constraint_pairs(a, b, n)
        assert len(s) == len(d) == 5 + n - 1
        if n > 1:
            assert np.array_equal(s[5:], a.path[boundaries(len(a.path), n)])
            assert np.array_equal(d[5:], b.path[boundaries(len(b.path), n)])
    # the waypoint pairs up only when both trials have one
    assert len(shared_icps(trials[8], trials[9])[0]) == 6


def test_boundaries_are_the_inner_cuts_of_equal_segments():
    assert boundaries(40, 1) == []
    assert boundaries(40, 4) == [10, 20, 30]
    assert boundaries(41, 2) == [20]


def test_score_resamples_the_shorter_path():
    t = np.linspace(0, 1, 31)
    long = np.column_stack([t, np.sin(3 * t)])
    short = long[::3]  # 11 points spanning the same time
    r, d = score(short, long)
    assert r > 0.9999 and d < 1e-3
    assert r == pytest.approx(correlation(short, long)) and d == pytest.approx(msd(short, long))


def test_table2_table3_group_pairs_by_setup(result):
    t2, t3 = tables.table2(result), tables.table3(result)
    assert t2.shape == t3.shape == (4, 5, 5)
    # slow reference for one cell: output exp3 (rows), input exp5 (columns), N = 2
    S = result.trial_setup
    vals = [result.r["osila"][1, i, j] for i in range(len(S)) for j in range(len(S)) if S[i] == 4 and S[j] == 2]
    assert t2[1, 2, 4] == pytest.approx(np.mean(vals))
    vals = [result.msd["osila"][1, i, j] for i in range(len(S)) for j in range(len(S)) if S[i] == 4 and S[j] == 2]
    assert t3[1, 2, 4] == pytest.approx(np.mean(vals))


def test_printed_tables_have_the_papers_layout(result):
    text = tables.render(result)
    for title in ("TABLE I:", "TABLE II:", "TABLE III:", "Summary", "Methods side by side"):
        assert title in text
    t1 = tables.format_table1(result).splitlines()
    assert t1[1].split("|")[1:] and [c.strip() for c in t1[1].split("|")[1:]] == ["exp1", "exp2", "exp3", "exp4", "exp5"]
    assert [ln.split("|")[0].strip() for ln in t1[2:]] == ["1", "2", "3", "4"]
    # the paper's figure beside ours: Table I exp3 N=1 is 0.991 in the paper
    assert "(0.991)" in t1[2].split("|")[3]
    t2 = tables.format_table2(result).splitlines()
    rows = [ln for ln in t2 if re.match(r"^(exp\d)?\s*\|\s+\d \|", ln)]
    assert len(rows) == 20
    assert [ln.split("|")[0].strip() for ln in rows[::4]] == ["exp1", "exp2", "exp3", "exp4", "exp5"]
    # output exp1, N = 1, input exp5: the paper's 0.380 sits beside our own value
    ours = tables.table2(result)[0, 0, 4]
    assert f"{ours:.3f} (0.380)" in rows[0]
    t3 = tables.format_table3(result)
    assert f"{tables.table3(result)[0, 0, 4]:.0f} (8390)" in t3


def test_paper_shares_follow_from_its_table():
    # the paper's 32 % / 92 % / "nearly all" are shares of its 25 Table II cells
    assert tables.share(paper.TABLE_II[0], "<", 0.8) == pytest.approx(8 / 25)
    assert tables.share(paper.TABLE_II[1], ">=", 0.8) == pytest.approx(23 / 25)
    assert tables.share(paper.TABLE_II[3], ">", 0.95) == pytest.approx(24 / 25)
    assert paper.TABLE_II[0, 0, 4] == 0.380 and paper.TABLE_II[0, 4, 0] == 0.835  # [N, output, input]


def test_summary_counts_cells_and_pairs(result):
    rows = {r["claim"]: r for r in tables.summary(result)}
    below = rows["unsegmented_below_0.8"]
    assert below["pairs"] == pytest.approx(float((result.r["osila"][0] < 0.8).mean()))
    assert below["cells"] == pytest.approx(float((tables.table2(result)[0] < 0.8).mean()))
    assert below["paper_cells"] == pytest.approx(0.32)


def test_tps_peer_is_exact_on_self_mapping_and_close_to_osila(result):
    diag = np.diagonal(result.r["tps"], axis1=1, axis2=2)
    assert (diag > 1 - 1e-9).all()
    assert np.nanmean(np.abs(result.r["tps"] - result.r["osila"])) < 0.02


def test_dmp_peer_hits_start_boundaries_and_goal(trials):
    pytest.importorskip("movement_primitives")
    from hila_lang.evaluation.peers import DmpPeer

    template, task = trials[0], trials[5]
    peer = DmpPeer(template.path)
    for n in (1, 3):
        path = peer.generate(task, n)
        assert path.shape == template.path.shape
        assert np.allclose(path[0], task.path[0], atol=1e-9)
        assert np.linalg.norm(path[-1] - task.path[-1]) < 3.0
        cuts = boundaries(len(template.path), n)
        for a, b in zip(cuts, boundaries(len(task.path), n)):
            assert np.allclose(path[a], task.path[b], atol=1e-9)


def test_hila_variant_stitches_one_osila_per_segment(trials):
    from hila_lang.evaluation.grid import _generator
    from hila_lang.segmentation import equal_segments

    template, task = trials[2], trials[7]  # exp2 -> exp4
    gen = _generator("hila", template, OPTIONS)
    assert np.array_equal(gen(task, 1), _generator("osila", template, OPTIONS)(task, 1))
    for n in (2, 4):
        path = gen(task, n)
        assert len(template.path) - (n - 1) <= len(path) <= len(template.path)  # joints kept once
        # starts at the task's hand, passes each inner segment end of the task path (threshold 2)
        assert np.allclose(path[0], task.icps[task.icp_names.index("hand")])
        for _, stop in equal_segments(len(task.path), n)[:-1]:
            assert np.linalg.norm(path - task.path[stop - 1], axis=1).min() <= 2.0 + 1e-9
    row = evaluate_row(trials, 2, methods=("osila", "hila"), options=OPTIONS)
    assert not row.failures["hila"]
    # no joint repeated: a pinned start that the warp meets only to rounding is still one point
    for task in trials[:10]:
        for n in (2, 3, 4):
            path = gen(task, n)
            assert np.linalg.norm(np.diff(path, axis=0), axis=1).min() > 1e-6
    assert row.r["hila"][:, 2].min() >= 0.998  # self-mapping
    assert np.abs(np.nanmean(row.r["hila"], 1) - np.nanmean(row.r["osila"], 1)).max() < 0.02


def test_peer_rows_report_time_per_path(result):
    rows = tables.peer_rows(result)
    assert {(r["method"], r["segments"]) for r in rows} == {(m, n) for m in ("osila", "tps", "dmp") for n in (1, 2, 3, 4)}
    assert all(r["ms_per_path"] > 0 and r["failures"] == 0 for r in rows)


def test_joblib_gives_the_local_numbers(trials, result):
    par = run_grid(trials, options=OPTIONS, jobs=2, progress=False)
    assert par.backend == "joblib(2)"
    assert np.array_equal(par.r["osila"], result.r["osila"])
    assert np.array_equal(par.msd["osila"], result.msd["osila"])


def test_a_failing_pair_scores_nan_and_is_reported(trials):
    row = evaluate_row(trials, 0, segments=(1, 2), options={"threshold": 2.0, "rounds": 0})
    assert row.r["osila"].shape == (2, len(trials)) and np.isnan(row.r["osila"]).all()
    assert len(row.failures["osila"]) == 2 * len(trials)
    assert row.failures["osila"][0].startswith("N=1 exp1/trial01 -> exp1/trial01: expected rounds >= 1")


def test_progress_bar_reports_every_tenth_when_not_a_terminal():
    buf = io.StringIO()
    bar = Progress(20, stream=buf)
    for _ in range(20):
        bar.update()
    lines = buf.getvalue().splitlines()
    assert 10 <= len(lines) <= 11 and lines[-1].startswith("eval [") and "20/20 rows" in lines[-1]
