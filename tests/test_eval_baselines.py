"""Issue 25: byte-identical results, the leak-free protocol, the baselines, the ablation, shape-level tests."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hila_lang import cli, metrics
from hila_lang.evaluation import ablation, baselines, protocols, stats
from hila_lang.evaluation.dataset import Trial, generate
from hila_lang.osila import imitate


# ----------------------------------------------------------------------------- deterministic output


def _run(out, *extra):
    argv = ["eval", "--protocol", "positions", "--trials-per-setup", "2", "--seed", "4", "--out", str(out),
            "--methods", "osila,similarity,laplacian,gp+retime,osila-tps", "--no-progress", *extra]
    assert cli.main(argv) == 0


@pytest.mark.slow
def test_results_json_is_byte_identical_for_the_same_seed(tmp_path, capsys):
    _run(tmp_path / "a")
    _run(tmp_path / "b", "--jobs", "2")  # another backend, another clock
    a, b = (tmp_path / "a" / "results.json").read_bytes(), (tmp_path / "b" / "results.json").read_bytes()
    assert a == b
    timings = json.loads((tmp_path / "b" / "timings.json").read_text())
    assert timings["backend"] == "joblib(2)" and timings["wall_seconds"] > 0
    doc = json.loads(a)
    assert doc["run"]["protocol"] == "positions" and doc["run"]["segments"] == [1, 2, 3, 4]
    assert doc["run"]["better"]["r"] == "higher" and doc["run"]["time_free"]["frechet"] is True
    _run(tmp_path / "c", "--seed", "5")  # another stand-in: other numbers
    assert (tmp_path / "c" / "results.json").read_bytes() != a
    capsys.readouterr()


# ----------------------------------------------------------------------------- metrics registry


def test_metrics_are_registered_once_with_their_direction():
    assert metrics.names(2) == ("r", "msd", "frechet", "dtw", "endpoint", "r_x", "r_y")
    assert [metrics.metric(n).better for n in ("r", "msd", "frechet", "r_y")] == ["higher", "lower", "lower", "higher"]
    assert [n for n in metrics.names(3) if metrics.metric(n).time_free] == ["frechet", "dtw", "endpoint"]
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(30, 2)).cumsum(0), rng.normal(size=(30, 2)).cumsum(0)
    got = dict(zip(metrics.names(2), metrics.scores(a, b)))
    assert got["frechet"] == pytest.approx(metrics.frechet(a, b)) and got["msd"] == pytest.approx(metrics.msd(a, b))
    metrics.register("span", "distance", time_free=True, unit="u")(lambda a, b, c: float(np.ptp(a - b)))
    try:  # one registration: a new metric is scored and named
        assert metrics.names(2)[-1] == "span" and len(metrics.scores(a, b)) == 8
    finally:
        del metrics.METRICS["span"]
    with pytest.raises(Exception, match="unknown metric 'speed'"):
        metrics.metric("speed")
    with pytest.raises(ValueError, match="expected kind = 'correlation' or 'distance'"):
        metrics.register("x", "lower", time_free=True, unit="u")


def test_tables_statistics_and_plots_read_a_metrics_kind_not_its_name():
    """A distance named like R ('rmse') is printed and plotted as a distance, a correlation named
    otherwise ('agreement') as a correlation: the registry's kind decides, not the first letter."""
    from hila_lang.evaluation import report, tables
    from hila_lang.evaluation.run import GridResult

    metrics.register("rmse", "distance", time_free=False, unit="u", title="RMSE", paper=True)(lambda a, b, c: 0.0)
    metrics.register("agreement", "correlation", time_free=False, unit="", paper=True)(lambda a, b, c: 0.0)
    try:
        rng = np.random.default_rng(3)
        J, names = 4, ("agreement", "rmse")
        scores = {m: np.stack([rng.uniform(0.6, 0.99, (1, J, J)), rng.uniform(1.0, 500.0, (1, J, J))], -1)
                  for m in ("osila", "tps")}
        scores["tps"][0, 0, 1] = np.nan  # a failed pair has no score
        result = GridResult([f"s{i // 2}/t{i}" for i in range(J)], np.array([0, 0, 1, 1]), ["s0", "s1"], (1,),
                            ("osila", "tps"), "positions", names, ~np.eye(J, dtype=bool), scores,
                            {m: np.zeros((1, J, J)) for m in scores}, {"osila": [], "tps": ["t0 -> t1"]})
        summary = tables.format_summary(result).splitlines()
        head = [c.strip() for c in summary[1].split("|")]
        assert "rmse" in head and "agreement" not in head  # the distance is summarised, the correlation kept aside
        assert tables._fmt(0.123456, "rmse") == "0.1235" and tables._fmt(0.5, "agreement") == "0.500"
        rows = {r["method"]: r for r in stats.summary_rows(result)}
        assert rows["tps"]["failed"] == 1 and rows["osila"]["failed"] == 0 and rows["osila"]["pairs"] == J * (J - 1)
        assert {"agreement", "rmse"} <= set(stats.by_setup(result)[0])
        doc = report.results_dict(result)
        assert doc["run"]["kind"] == {"agreement": "correlation", "rmse": "distance"}
        assert doc["run"]["better"] == {"agreement": "higher", "rmse": "lower"}
        corr, dist = report.heatmap(result, "osila", "agreement"), report.heatmap(result, "osila", "rmse")
        assert corr.shape == dist.shape and not np.array_equal(corr, dist)  # each on its own scale
    finally:
        del metrics.METRICS["rmse"], metrics.METRICS["agreement"]


# ----------------------------------------------------------------------------- the leak-free protocol


def _trial(path, setup="s", name="t"):
    return Trial(setup, name, path, (), np.zeros((0, path.shape[1])))


def test_positions_protocol_tells_no_time():
    u = np.linspace(0.0, 1.0, 2001)
    shape = lambda v: np.column_stack([np.cos(3 * v), np.sin(2 * v) + v])  # noqa: E731
    even = _trial(shape(u))
    late = _trial(shape(u**2))  # the same drawing, the person slow at first then fast
    template = _trial(shape(np.linspace(0.0, 1.0, 80)) * 1.1)
    for n in (1, 2, 3, 4):
        a = protocols.constraints(template, even, n, "positions")
        b = protocols.constraints(template, late, n, "positions")
        np.testing.assert_allclose(a.dst, b.dst, atol=2e-3)  # where, not when
        np.testing.assert_array_equal(a.src, b.src)
        assert a.labels[-1] == f"s = {n}/{n}" and len(a.src) == n + 1
        f_even = protocols.constraints(template, even, n, "fractions")
        f_late = protocols.constraints(template, late, n, "fractions")
        if n > 1:  # the time fractions move with the timing: that is the leak
            assert np.abs(f_even.dst - f_late.dst).max() > 0.05
    assert not protocols.leaks_time("positions", 4) and protocols.leaks_time("fractions", 2)
    assert not protocols.leaks_time("fractions", 1) and not protocols.leaks_time("held-out", 1)


def test_positions_on_scene_data_keeps_the_icps_and_adds_inner_points():
    trials = generate(seed=0, trials_per_setup=1)
    c = protocols.constraints(trials[0], trials[3], 3, "positions")
    names = protocols.shared_names(trials[0], trials[3])
    assert c.labels == (*names, "s = 1/3", "s = 2/3") and c.at[: len(names)] == (None,) * len(names)


# ----------------------------------------------------------------------------- baselines


@pytest.fixture(scope="module")
def pair():
    u = np.linspace(0.0, 1.0, 60)
    template = _trial(np.column_stack([u, np.sin(3 * u)]), name="a")
    task = _trial(np.column_stack([1.2 * u + 0.1, 1.1 * np.sin(3.3 * u) + 0.2 * u]), name="b")
    return template, task


def test_laplacian_editing_is_the_constrained_least_squares(pair):
    template, task = pair
    c = protocols.constraints(template, task, 3, "positions")
    out = baselines.laplacian(template.path, c)
    idx, points = baselines.anchors(template.path, c)
    np.testing.assert_allclose(out[idx], points, atol=1e-12)
    # the reference: the KKT system of min |L q - L p_aligned|² subject to q[idx] = points
    aligned = baselines._apply(baselines.similarity(c), template.path)
    T = len(aligned)
    L = np.eye(T)
    for t in range(T):
        nb = [s for s in (t - 1, t + 1) if 0 <= s < T]
        L[t, nb] -= 1.0 / len(nb)
    C = np.zeros((len(idx), T))
    C[np.arange(len(idx)), idx] = 1.0
    kkt = np.block([[2 * L.T @ L, C.T], [C, np.zeros((len(idx), len(idx)))]])
    rhs = np.vstack([2 * L.T @ L @ aligned, points])
    np.testing.assert_allclose(out, np.linalg.solve(kkt, rhs)[:T], atol=1e-8)
    assert np.abs(out - aligned).max() > 1e-3  # it edits


def test_promp_conditioned_point_by_point_equals_joint_conditioning(pair):
    pytest.importorskip("movement_primitives")
    from movement_primitives.promp import ProMP

    template, task = pair
    c = protocols.constraints(template, task, 4, "positions")
    idx, points = baselines.anchors(template.path, c)
    aligned = baselines._apply(baselines.similarity(c), template.path)
    off = points - aligned[idx]
    got = baselines.promp_offset(60, idx, off)
    # joint conditioning of the weight prior N(0, I) on every anchor at once, one dimension at a time
    p = ProMP(n_dims=1)
    t = idx / 59.0
    Psi = np.array([p._rbfs_1d_point(x) for x in t])  # (A, W)
    Phi = p._rbfs_1d_sequence(np.linspace(0.0, 1.0, 60)).T  # (T, W)
    want = Phi @ Psi.T @ np.linalg.solve(Psi @ Psi.T, off)
    np.testing.assert_allclose(got, want, atol=1e-8)
    out = baselines.promp(template.path, c)
    np.testing.assert_allclose(out[idx], points, atol=1e-12)


def test_gp_matches_scikit_learn_and_its_length_scale_comes_from_the_template(pair):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF

    template, _ = pair
    idx, off = np.array([0, 20, 45, 59]), np.random.default_rng(0).normal(size=(4, 2))
    u = np.linspace(0.0, 1.0, 60)
    want = GaussianProcessRegressor(RBF(0.3), optimizer=None).fit(u[idx][:, None], off).predict(u[:, None])
    np.testing.assert_allclose(baselines.gp_offset(60, idx, off, 0.3), want, atol=1e-9)
    slow = baselines.template_length_scale(np.column_stack([u, np.sin(2 * u)]))
    fast = baselines.template_length_scale(np.column_stack([u, np.sin(20 * u)]))
    assert fast < slow  # a quicker movement, a shorter length scale


def test_retime_variants_use_osilas_retiming(pair):
    from hila_lang.osila.timing import TIMING, retime

    template, task = pair
    c = protocols.constraints(template, task, 3, "fractions")  # points at time fractions: timed pairs
    moved = retime(template.path, c.src, c.dst, TIMING, times=c.times)
    assert moved.stamps  # something moved on this pair
    got = baselines.generator("laplacian+retime", template.path)(c)
    want = baselines.laplacian(moved.path, protocols.Constraints(moved.src, c.dst, c.labels, c.at, c.n))
    np.testing.assert_array_equal(got, want)
    assert np.abs(got - baselines.generator("laplacian", template.path)(c)).max() > 1e-6
    # positions carry no time: OSILA's re-timing moves nothing, and X+retime is X
    c = protocols.constraints(template, task, 3, "positions")
    np.testing.assert_array_equal(baselines.generator("laplacian+retime", template.path)(c),
                                  baselines.generator("laplacian", template.path)(c))


# ----------------------------------------------------------------------------- ablation


def test_the_composed_osila_is_osila_so_the_warp_rows_differ_by_the_warp_only():
    trials = generate(seed=2, trials_per_setup=2)
    for i, j, n, protocol in ((0, 5, 1, "held-out"), (3, 8, 3, "paper"), (2, 9, 4, "positions"), (6, 1, 2, "positions")):
        c = protocols.constraints(trials[i], trials[j], n, protocol)
        path = trials[i].path
        np.testing.assert_array_equal(ablation.variant(path, c, "auto", {"threshold": 2.0}),
                                      imitate(path, c.src, c.dst, threshold=2.0, task_times=c.times))
    c = protocols.constraints(trials[3], trials[8], 3, "positions")
    sim = ablation.generator("osila-similarity", trials[3].path, {"threshold": 2.0})(c)
    tps = ablation.generator("osila-tps", trials[3].path, {"threshold": 2.0})(c)
    assert np.abs(sim - tps).max() > 1.0
    noroute = ablation.generator("osila-noroute", trials[3].path, {"threshold": 2.0})(c)
    np.testing.assert_array_equal(noroute, imitate(trials[3].path, c.src, c.dst, threshold=0.0))
    noadjust = ablation.generator("osila-noadjust", trials[3].path, {"threshold": 2.0})(c)
    np.testing.assert_array_equal(noadjust, imitate(trials[3].path, c.src, c.dst, threshold=2.0, rounds=1))


# ----------------------------------------------------------------------------- statistics


def test_holm_and_the_shape_level_comparison():
    np.testing.assert_allclose(stats.holm(np.array([0.01, 0.04, 0.03, np.nan])), [0.03, 0.06, 0.06, np.nan])
    osila = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    other = osila + np.array([0.5, 0.1, 0.3, -0.2, 0.4, 0.6])
    row = stats.compare(osila, other, "lower")
    assert row["n"] == 6 and row["osila_better_share"] == pytest.approx(5 / 6)
    assert row["median_diff"] == pytest.approx(-0.35) and row["ci_low"] <= -0.35 <= row["ci_high"]
    assert row == stats.compare(osila, other, "lower")  # seeded bootstrap
    assert stats.compare(osila, other, "higher")["osila_better_share"] == pytest.approx(1 / 6)


def test_protocols_are_checked_against_the_data(tmp_path, capsys):
    assert cli.main(["eval", "--protocol", "fractions", "--out", str(tmp_path), "--trials-per-setup", "1"]) == 2
    assert "--protocol fractions is for --dataset lasa" in capsys.readouterr().err


# ----------------------------------------------------------------------------- the confirmatory family


def _grid(scores: dict, segments=(1, 2), setups=4, per=2):
    """A GridResult of made-up scores: ``scores[method]`` (S, J, J, M) for J = setups x per trials."""
    from hila_lang.evaluation.run import GridResult

    J = setups * per
    trial_setup = np.repeat(np.arange(setups), per)
    mask = (trial_setup[:, None] == trial_setup[None, :]) & ~np.eye(J, dtype=bool)
    return GridResult([f"s{k}/t{i}" for k in range(setups) for i in range(per)], trial_setup,
                      [f"s{k}" for k in range(setups)], tuple(segments), tuple(scores), "positions",
                      metrics.names(2), mask, scores=scores, seconds={m: np.zeros((len(segments), J, J)) for m in scores})


def test_holm_runs_within_the_declared_family_and_everything_else_is_exploratory():
    rng = np.random.default_rng(0)
    J, M = 8, len(metrics.names(2))
    base = rng.uniform(1, 2, (2, J, J, M))
    scores = {"osila": base, "similarity": base + rng.uniform(0, 1, base.shape),
              "laplacian": base + rng.uniform(-0.2, 1, base.shape), "promp": base + rng.uniform(0, 1, base.shape),
              "promp+retime": None, "osila-noadjust": base.copy()}
    scores["promp+retime"] = scores["promp"].copy()  # re-timing changed nothing: the same on every pair
    result = _grid(scores)
    assert stats.confirmatory(result) == [("laplacian", 2, "frechet"), ("promp", 2, "frechet"),
                                          ("promp+retime", 2, "frechet")]
    rows = {(r["method"], r["segments"], r["metric"]): r for r in stats.test_rows(result)}
    conf = [r for r in rows.values() if r["family"] == "confirmatory"]
    assert {(r["method"], r["segments"], r["metric"]) for r in conf} == set(stats.confirmatory(result))
    # the duplicate is said once: it carries its twin's figures and does not count twice in Holm
    dup = rows[("promp+retime", 2, "frechet")]
    assert dup["same_as"] == "promp" and dup["p_value"] == rows[("promp", 2, "frechet")]["p_value"]
    counted = [rows[("laplacian", 2, "frechet")], rows[("promp", 2, "frechet")]]
    np.testing.assert_allclose([r["p_holm"] for r in counted], stats.holm(np.array([r["p_value"] for r in counted])))
    assert dup["p_holm"] == rows[("promp", 2, "frechet")]["p_holm"]
    # everything else is exploratory: the controls, N = 1, the other metrics; no Holm there
    for key in [("similarity", 2, "frechet"), ("laplacian", 1, "frechet"), ("laplacian", 2, "dtw")]:
        assert rows[key]["family"] == "exploratory" and np.isnan(rows[key]["p_holm"])
    # a method identical to OSILA is a tie, not a loss
    tie = rows[("osila-noadjust", 2, "frechet")]
    assert tie["same_as"] == "osila" and tie["tied_share"] == 1.0 and tie["osila_better_share"] == 0.0
    assert tie["osila_worse_share"] == 0.0 and tie["p_value"] == 1.0
    assert stats.duplicates(result)[2] == {"promp+retime": "promp", "osila-noadjust": "osila"}


def test_ties_are_counted_as_ties():
    row = stats.compare(np.array([1.0, 2.0, 3.0, 4.0]), np.array([1.0, 2.5, 2.0, 4.0]), "lower")
    assert (row["osila_better_share"], row["tied_share"], row["osila_worse_share"]) == (0.25, 0.5, 0.25)


def test_the_tables_say_duplicates_once_and_name_the_family(capsys):
    from hila_lang.evaluation import tables

    rng = np.random.default_rng(1)
    base = rng.uniform(1, 2, (2, 8, 8, len(metrics.names(2))))
    scores = {"osila": base, "laplacian": base + 0.1, "laplacian+retime": base + 0.1, "osila-noretime": base.copy()}
    text = tables.render(_grid(scores), tables=False)
    row = next(line for line in text.splitlines() if line.startswith("laplacian+retime |"))
    assert [c.strip() for c in row.split("|")[1:]] == ["= laplacian", "= laplacian"]  # not its numbers again
    assert "CONFIRMATORY family, declared in advance (frechet, OSILA against each baseline, N = 2): 1 distinct tests" in text
    assert "EXPLORATORY" in text and "laplacian+retime = laplacian at N = 1, 2" in text
    assert "osila-noretime = osila (a tie with OSILA) at N = 1, 2" in text


# ----------------------------------------------------------------------------- re-timing asks the pairs


def test_only_protocols_that_give_a_time_give_osila_task_times():
    tr = generate(seed=2, trials_per_setup=2)
    a, b = tr[0], tr[3]
    assert protocols.constraints(a, b, 3, "positions").times is None
    assert protocols.constraints(a, b, 1, "held-out").times is None
    paper = protocols.constraints(a, b, 3, "paper")
    assert [t is None for t in paper.times] == [at is None for at in paper.at]  # scene ICPs: positions
    assert [round(t * (len(b.path) - 1)) for t in paper.times if t is not None] == protocols.boundaries(len(b.path), 3)


def test_timing_reaches_every_retime_baseline():
    from hila_lang.osila.timing import retime

    tr = generate(seed=2, trials_per_setup=2)
    c = protocols.constraints(tr[0], tr[3], 3, "paper")
    for name in ("promp+retime", "laplacian+retime", "gp+retime"):
        if name.startswith("promp"):
            pytest.importorskip("movement_primitives")
        wide = baselines.generator(name, tr[0].path, {"timing": 0.1})(c)
        none = baselines.generator(name, tr[0].path, {"timing": 0.0})(c)
        plain = baselines.generator(name.split("+")[0], tr[0].path, {})(c)
        np.testing.assert_array_equal(none, plain)  # timing 0: nothing re-timed, the plain baseline
        moved = retime(tr[0].path, c.src, c.dst, 0.1, times=c.times)
        assert moved.stamps and not np.array_equal(wide, plain)  # the spread given is the one used
